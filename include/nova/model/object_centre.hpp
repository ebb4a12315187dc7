#pragma once
// Where an object is: the centre a compose-spec instance without pivot= turns about
// (compose_spec.hpp). The renderer probes the object NeRF's density at the instance's time on
// a regular grid of cell centres over the field's box (ViewRenderer::object_centre) and hands
// the densities to density_centroid, which works on the host alone.
//
// The centre lives where the spec's transform applies: the scene's processed world
// coordinates. A metric field is already there. An NDC field (forward-facing scenes) is not:
// the density-weighted mean is taken in the field's NDC coordinates and that point is mapped
// NDC -> world (the inverse of the rays' NDC map, as instance_points does: z = 2 n /
// (z_ndc - 1), x = x_ndc z / ax, y = y_ndc z / ay). NDC x and y are image coordinates, so
// the pivot lies on the line of sight through the object's density-weighted image centre,
// and its depth is the mean disparity's. Averaging world points instead (each cell mapped to
// the world and weighted by its world mass) would be exact for a compact solid but is
// unbounded: an object NeRF of a monocular video keeps density spread along its rays, up to
// the far plane (world depth -> infinity), hidden behind the background in every render;
// on a 400-step run of the default scene that put the pivots 80-120 units behind the
// objects (true depths 1.4-2.2). The NDC mean stays in the box: for a compact object it is
// the world centre up to second order in its depth extent over its distance (measured in
// tests/test_object_centre.cpp), and a streak along the rays pulls its depth, not its
// place in the image.
//
// Which cells count, and with what weight:
// - A cell counts when its density would make a sample one probe cell long at least
//   `alpha` opaque, alpha = 1 - exp(-sigma * cell) (field units, as the occupancy grids'
//   test). 0.1 rather than the grids' 0.01: the grids must never drop what a ray could
//   show, while the centre should be the object's body, not the faint haze a NeRF leaves
//   around it (haze spread over the whole box drags a centroid towards the box centre). A
//   fixed opacity rather than a fraction of the maximum for solid objects: one spiky cell
//   would move a fraction-of-max threshold, and with it the whole selection.
// - A faint object (a short training run: no cell reaches `alpha`) still has a centre: the
//   threshold is the lower of that opacity and `max_fraction` of the largest density, so its
//   densest part counts. Only where no cell reaches `floor_alpha` (the occupancy grids'
//   default: what a render would skip as empty) has the object no centre at that time.
// - Its weight is its density (field units).
// Sums run in double in cell order: the same densities give the same centre, bit for bit.
#include <array>
#include <cstddef>
#include <vector>

namespace nova {

struct CentroidOptions {
  double alpha = 0.1;          // opacity over one probe cell that counts (see above)
  double max_fraction = 0.5;   // ... or this fraction of the largest density, if lower
  double floor_alpha = 0.01;   // no cell this opaque: no centre
  // The field's coordinates: NDC with the rays' constants (ax = -fx / cx, ay = -fy / cy,
  // near plane `ndc_near`), or metric (already world).
  bool ndc = false;
  double ax = -1.0, ay = -1.0, ndc_near = 1.0;
};

struct Centroid {
  bool found = false;                // some cell passed the floor (and so the threshold)
  std::array<double, 3> centre{};    // world (scene processed) coordinates
  std::array<double, 3> field_centre{};  // the same point in field coordinates (NDC or metric)
  size_t cells = 0;                  // cells that passed
  double max_density = 0;            // largest probed density (field units)
};

// The centre of a cell c (x fastest) of a G^3 grid over [-bound, bound]^3, field coordinates.
std::array<double, 3> probe_cell_centre(size_t c, int resolution, double bound);

// A field point in world coordinates (identity for a metric field). Points at or beyond the
// NDC far plane (z_ndc >= 1) are clamped just short of it, as instance_points does.
std::array<double, 3> field_to_world(const std::array<double, 3>& p, const CentroidOptions& options);

// The centroid of `density` (G^3 values at the cell centres, field units, x fastest; a
// negative or non-finite value counts as no density) by the rule above.
Centroid density_centroid(const std::vector<float>& density, int resolution, double bound,
                          const CentroidOptions& options = {});

}  // namespace nova

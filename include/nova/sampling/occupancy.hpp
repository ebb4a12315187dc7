#pragma once
// Skipping empty space: one occupancy grid per NeRF and the packed-sample ops that drop the
// samples in empty cells before any MLP runs (nerfacc's idea, on nova's static graphs).
//
// A grid covers the field's box [-bound, bound]^3 with G^3 cells and keeps, per cell, a
// decayed maximum of the density the NeRF gave at points in it (for an object NeRF, at
// several times: the maximum over time). A cell is occupied when that density would make a
// sample one cell long at least `alpha` opaque, or when it has never been evaluated, so a
// fresh grid skips nothing. Points outside the box count as in the nearest cell, as the hash
// grid clamps them.
//
// In a graph, packing is three ops:
//   Packed p = pack_occupied(positions, select);  // which samples survive, as row indices
//   x' = gather_rows(x, p)                          // [B, C, D]: C rows allocated, live used
//   ... MLP on x' (row-wise ops follow the live count, see Graph::add_extent) ...
//   raw = scatter_rows(y', p, fill)                 // back to [B, M, C_out]; dropped rows = fill
#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "nova/graph/graph.hpp"
#include "nova/runtime/runtime.hpp"

namespace nova {

struct OccupancyGrid {
  int resolution = 64;
  float bound = 1.0f;
  float alpha = 0.01f;          // opacity over one cell that counts as occupied
  std::vector<float> density;   // G^3, x fastest; < 0: never evaluated (occupied)
  std::vector<uint8_t> occupied;
  // Where the field is defined at all (lo x, y, z, hi x, y, z; empty: the whole grid): a
  // cell that does not meet this box is empty whatever its density, and so is a point
  // beyond the grid that clamps into such a cell (a rigid object's box, object-box-bounded).
  std::vector<float> support;
  // Changes (to a value no grid had before) whenever `occupied` is recomputed: the pack op
  // copies the cells to the device again only when a grid's generation moves. Change
  // `density` or `occupied` only through update() + refresh().
  uint64_t generation = 0;

  OccupancyGrid() = default;
  OccupancyGrid(int resolution, float bound, float alpha);
  size_t cells() const { return density.size(); }
  float cell_size() const { return 2.0f * bound / static_cast<float>(resolution); }
  // Density above which a cell is occupied: -log(1 - alpha) / cell size.
  float threshold() const;
  size_t cell_of(const float* p) const;
  // The point of cell c at offsets u in [0, 1)^3 inside it.
  void point_in(size_t c, const float* u, float* p) const;
  // Folds new densities at cells into the grid: d = max(decay * d, new).
  void update(const std::vector<size_t>& cells, const std::vector<float>& densities, float decay);
  // Sets `support` (6 floats, or empty for none) and refreshes.
  void set_support(std::vector<float> box);
  // Recomputes `occupied` from `density` and `support`, and takes a new generation.
  void refresh();
  double occupied_fraction() const;
};

// Early ray termination's part of a packing (view_renderer.cpp): with samples_per_ray S > 0
// the rows of every batch are ray-major (row m is sample m % S of ray m / S) and a row
// survives only if first <= m % S < end and its ray is open, open_rays[m / S] != 0: one byte
// per ray on the device, written by the renderer's termination kernels (null: every ray
// open). S = 0 applies no such rule.
struct SampleRange {
  size_t samples_per_ray = 0, first = 0, end = 0;
  cl_mem open_rays = nullptr;  // borrowed from the renderer
  size_t open_rays_count = 0;  // rays it holds a flag for
};

// What a pack op tests its samples against: one grid per NeRF and, per batch of the packed
// positions, which grid, and a sample range. The owner may change all of them between runs
// (a renderer placing other objects, a termination pass); `enabled` false (or no grids)
// keeps every sample the grids would drop.
struct PackSelect {
  std::shared_ptr<const std::vector<OccupancyGrid>> grids;
  std::vector<int> grid_of_batch;
  bool enabled = true;
  SampleRange range;
  // Written by the pack op on every run: samples kept over all batches, and samples tested.
  size_t kept = 0, tested = 0;
};

struct Packed {
  Tensor index;   // [B, C, 1] or [C, 1]: dense row per packed row, -1 for padding
  int extent = -1;
  size_t batches = 1, dense_rows = 0;
};

// Tests positions [M, 3] or [B, M, 3] (field coordinates) against their grids and packs the
// survivors of each batch, all on the device (a flag per row, block counts, a prefix sum in a
// fixed order, an ordered write); the live row count is the largest batch's, rounded up to a
// multiple of `multiple` (GEMM-friendly), at least `multiple`. The host reads B counts per
// run, never a per-sample buffer. Forward only: positions are data.
Packed pack_occupied(Tensor positions, std::shared_ptr<PackSelect> select, size_t multiple = 32);
// x [M, D] (shared by every batch) or [B, M, D] -> [C, D] or [B, C, D], live rows filled.
Tensor gather_rows(Tensor x, const Packed& p);
// y [C, D] or [B, C, D] -> the dense [M, D] or [B, M, D]: packed rows at their index, every
// other row `fill` (D values). Differentiable in y.
Tensor scatter_rows(Tensor y, const Packed& p, const std::vector<float>& fill);

// The checkpoint array of grid k (0: static, k: object k): its densities, [G, G, G].
std::string occupancy_array_name(int k);

// The fill of a dropped field sample (raw layout of render.hpp): no density and no blend, so
// it neither occludes nor takes a share of another NeRF's blend.
std::vector<float> empty_raw_fill(size_t channels);

}  // namespace nova

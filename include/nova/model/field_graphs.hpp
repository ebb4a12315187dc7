#pragma once
// The graphs of a NOVA model besides its training steps: the render of a view with placed
// object instances and the density probes of the occupancy grids, with the field and
// sampling helpers the training step graphs (step_graphs.hpp) build from too, so that
// training and inference see the same fields and the same rays.
#include <array>
#include <memory>
#include <vector>

#include "nova/graph/graph.hpp"
#include "nova/model/fields.hpp"
#include "nova/sampling/occupancy.hpp"
#include "nova/sampling/rays.hpp"
#include "nova/render/render_composite.hpp"
#include "nova/model/scene.hpp"

namespace nova {

// What the graphs need to know of the scene: how rays are parameterised and sampled.
struct RayGeometry {
  bool ndc = false;
  float near = 0.0f, far = 1.0f;  // sample range (NDC: 0 and 1)
  float ax = -1.0f, ay = -1.0f;   // NDC constants -fx/cx, -fy/cy of the training cameras
  // Half-sizes along x, y, z of the box around the origin that holds what the cameras see:
  // in NDC the extent of every training ray in x and y (at least 1) and 1 in z (near plane
  // to infinity); else the largest camera-origin coordinate on every axis (cameras look in at
  // the scene). `extent` is the largest of the three.
  std::array<float, 3> box{1.0f, 1.0f, 1.0f};
  float extent = 1.0f;
  int num_objects = 0;
  bool disparity = false;  // every training frame has a disparity map
  // Frames the time axis [-1, 1] is divided into: 2 / the smallest gap between two frame
  // times, so holding frames out does not change it (0: a static scene or a single frame).
  int frames = 0;
};
RayGeometry ray_geometry(const Scene& scene);

// The field configuration with what depends on the scene filled in: the hash grid's box and,
// with hash_time_auto, its cells along time (frames / kFramesPerTimeCell, at least 1).
FieldConfig scene_field(const FieldConfig& f, const RayGeometry& g);

// Stratified sampling of `samples` per ray over g's depth range, NeRFs grouped as `groups`.
SampleOptions sample_options(int samples, const RayGeometry& g, std::vector<int> groups);
// What a pack op tests against (grid_of_batch[b]: batch b's grid); null, no packing, when !on.
std::shared_ptr<PackSelect> new_select(bool on, std::vector<int> grid_of_batch);
// The grids of object NeRFs 1..objects (grid 0 is the static NeRF's).
std::vector<int> object_grids(int objects);
// The static field on the samples `pack` keeps (every one without), the rest empty_raw_fill.
Tensor static_raw(Tensor positions, Tensor viewdirs, const FieldConfig& f, std::shared_ptr<PackSelect> pack);
// The object fields at `times` ([K, 1]: one time per object NeRF), on the samples `pack` keeps
// as static_raw. With a rigid motion the samples are moved into each object's canonical space
// first by `motion` (motion_parameter; the packing tests the canonical positions); without
// `motion` the positions are canonical already (a view: the renderer composes each object's
// motion at its time into the instance's transform). level_window: build_object_fields'.
Tensor object_raw(Tensor positions, Tensor times, const FieldConfig& f, const RayGeometry& g,
                  std::shared_ptr<PackSelect> pack, Tensor motion = {}, Tensor level_window = {});
// The rigid_motion options of the scene's time axis and rays.
MotionOptions motion_options(const RayGeometry& g);

struct ViewGraph {
  Graph graph;
  int rays = 0, instances = 0;
  bool background = true;
  // cameras: [N, 16], the view's camera N times; times [instances, 1]
  Tensor pixels, cameras, transforms, times;
  // With `warped`: where the samples crowd, [sample_warp_knots(instances), 2] knots
  // (object_sample_warp in object_samples.hpp, from the instances' pivots and radii).
  Tensor warp;
  RenderOutputs out;
  // With `packed`: the packing of the static samples and of the instances' samples (set
  // grid_of_batch to each instance's object grid), against occupancy grids and the sample
  // range of an early-termination pass.
  std::shared_ptr<PackSelect> pack_static, pack_objects;
};
// Inference: `rays` rays of one camera, the static NeRF when `background`, and `instances`
// object-NeRF copies each placed by a world-to-object transform at its own time.
std::unique_ptr<ViewGraph> build_view_graph(const FieldConfig& f, int samples, const RayGeometry& g,
                                            int rays, bool background, int instances,
                                            bool hard_blend, bool packed = false, bool warped = false);

// Density probes for the occupancy grids: the static field at `points` positions and, with
// objects > 0, every object field at `points` positions and times; the same parameter names
// as the training graphs, so their weights copy over by name.
struct DensityGraph {
  Graph graph;
  Tensor static_positions, static_viewdirs, static_raw;      // [P, 3], [P, 3], [P, 5]
  Tensor object_positions, object_times, object_raw;         // [K, P, 3], [K, P, 1], [K, P, 5]
};
std::unique_ptr<DensityGraph> build_density_graph(const FieldConfig& f, const RayGeometry& g, int objects,
                                                  int points);

}  // namespace nova

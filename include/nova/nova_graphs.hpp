#pragma once
// The graphs of a NOVA model: the static pretraining step, the joint training step and the
// inference render of a view with placed object instances. The trainer and the renderer
// both build from here, so training and inference see the same fields and the same rays.
#include <array>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "nova/distributed.hpp"
#include "nova/graph.hpp"
#include "nova/losses.hpp"
#include "nova/occupancy.hpp"
#include "nova/random.hpp"
#include "nova/render.hpp"
#include "nova/scene.hpp"
#include "nova/train_config.hpp"

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

struct StepGraph {
  Graph graph;
  int nerfs = 1;  // 1 (pretraining) or 1 + K
  // Data inputs, set every step (invalid when the graph has none); times is [K, 1], each
  // object's time.
  Tensor pixels, cameras, times, target_rgb, target_masks;
  // Drawn on the device every run (random.hpp): stratified jitter [R, S] and, with
  // noise_std > 0, density noise [N, R * S]. `draws` is their counter: set it to the step.
  Tensor jitter, noise;
  std::shared_ptr<DrawCounter> draws;
  // The targets of the depth and free-space terms (when either is built): minus the disparity
  // per ray, and 1 where it applies (0 on augmented steps, whose warped views have no disparity).
  Tensor target_depth, depth_valid;
  // [N, R, 3] each NeRF's own target colour: only under LossConventions::nerf_rgb_area.
  Tensor target_nerf_rgb;
  Tensor loss;
  std::vector<std::pair<std::string, Tensor>> terms;  // unweighted, for metrics
  Tensor psnr_mse;  // the composite-colour mse the progress PSNR is computed from
  // With TrainConfig::occupancy: what the static and the object samples are packed against
  // (null: no packing). Their grids are unset, so nothing is skipped until the owner sets them.
  std::shared_ptr<PackSelect> pack_static, pack_objects;
};

// Whether the scene's disparity can supervise depth: every frame has a map, and rays are NDC
// (where the rendered depth is affine in disparity; metric depth is not).
bool disparity_usable(const RayGeometry& g);
// Whether the graphs get the depth loss: a weight and usable disparity.
bool depth_term_active(const TrainConfig& c, const RayGeometry& g);

// The static NeRF alone on `rays` rays (background pixels): mse of its colour.
// With a slice (data-parallel training, distributed.hpp) the graph takes c.rays rays, the
// slice's share, and draws the randomness of those rays of the whole step.
std::unique_ptr<StepGraph> build_pretrain_graph(const TrainConfig& c, const RayGeometry& g, RaySlice slice = {});
// All 1 + K NeRFs with the novel-view losses of c.weights (K >= 1).
std::unique_ptr<StepGraph> build_joint_graph(const TrainConfig& c, const RayGeometry& g, RaySlice slice = {});

struct ViewGraph {
  Graph graph;
  int rays = 0, instances = 0;
  bool background = true;
  // cameras: [N, 16], the view's camera N times; times [instances, 1]
  Tensor pixels, cameras, transforms, times;
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
                                            bool hard_blend, bool packed = false);

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

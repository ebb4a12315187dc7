#pragma once
// The training step graphs of a NOVA model: the static pretraining step and the joint step
// of the static and the object NeRFs, with their loss terms and the step's randomness drawn
// on the device. They build their fields and samples with the helpers the view graphs use
// (nova_graphs.hpp), so training and inference see the same fields and the same rays.
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "nova/graph/distributed.hpp"
#include "nova/graph/graph.hpp"
#include "nova/model/field_graphs.hpp"
#include "nova/sampling/occupancy.hpp"
#include "nova/sampling/random.hpp"
#include "nova/train/train_config.hpp"

namespace nova {

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
  // [1] with TrainConfig::depth_ramp (pretraining): the depth term's share of w_depth this
  // step (TrainConfig::depth_weight_at).
  Tensor depth_weight;
  // [R] with TrainConfig::free_space_scene_fit (joint steps): each ray's free-space surface.
  Tensor free_space_surface;
  // [N, R, 3] each NeRF's own target colour: only under LossConventions::nerf_rgb_area.
  Tensor target_nerf_rgb;
  // The objects' rigid trajectories (motion.hpp) when the field has them: a parameter the
  // trainer sets from the masks on entering the joint phase.
  Tensor motion;
  // [levels * features] with TrainConfig::canonical_coarse_to_fine: the canonical grid's
  // coarse-to-fine window, set every joint step (level_window).
  Tensor level_window;
  Tensor loss;
  std::vector<std::pair<std::string, Tensor>> terms;  // unweighted, for metrics
  Tensor psnr_mse;  // the composite-colour mse the progress PSNR is computed from
  // With TrainConfig::occupancy: what the static and the object samples are packed against
  // (null: no packing). Their grids are unset, so nothing is skipped until the owner sets them.
  std::shared_ptr<PackSelect> pack_static, pack_objects;
};

// The coarse-to-fine window of a hash grid's `levels` levels of `features` columns each at
// `progress` in [0, 1] (BARF's): level l weighs (1 - cos(pi clamp(a - l, 0, 1))) / 2 with
// a = levels * progress, the coarsest level always 1; every level 1 from progress 1 on.
std::vector<float> level_window(int levels, int features, double progress);

// Whether the scene's disparity can supervise depth: every frame has a map, and rays are NDC
// (where the rendered depth is affine in disparity; metric depth is not).
bool disparity_usable(const RayGeometry& g);

// The static NeRF alone on `rays` rays (background pixels): mse of its colour.
// With a slice (data-parallel training, distributed.hpp) the graph takes c.rays rays, the
// slice's share, and draws the randomness of those rays of the whole step.
std::unique_ptr<StepGraph> build_pretrain_graph(const TrainConfig& c, const RayGeometry& g, RaySlice slice = {});
// All 1 + K NeRFs with the novel-view losses of c.weights (K >= 1).
std::unique_ptr<StepGraph> build_joint_graph(const TrainConfig& c, const RayGeometry& g, RaySlice slice = {});

}  // namespace nova

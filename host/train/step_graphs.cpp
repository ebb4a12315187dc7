#include "nova/train/step_graphs.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "nova/runtime/error.hpp"
#include "nova/loss/objective.hpp"
#include "nova/loss/terms.hpp"
#include "nova/sampling/rigid_motion.hpp"
#include "nova/ops/tensor/tensor_ops.hpp"
#include "nova/sampling/rays.hpp"
#include "nova/sampling/sample_warp.hpp"
#include "nova/model/object_samples.hpp"
#include "nova/render/render_composite.hpp"

namespace nova {
namespace {

// Streams of the step graphs' device draws (random.hpp).
constexpr uint32_t kJitterStream = 1, kNoiseStream = 2;

// The priors' weights of a configuration.
PriorWeights prior_weights(const TrainConfig& c) {
  PriorWeights p;
  p.depth = c.w_depth;
  p.free_space = c.w_free_space;
  p.free_space_margin = c.free_space_margin;
  p.free_space_behind = c.free_space_behind;
  p.distortion = c.w_distortion;
  p.motion_smooth = c.w_motion_smooth;
  p.free_space_surface_given = c.free_space_scene_fit;
  return p;
}

// The objective's terms and total into the step graph, with the disparity inputs it made.
void take_objective(StepGraph& s, Objective o, const DisparityTargets& disparity) {
  s.target_depth = disparity.target;
  s.depth_valid = disparity.valid;
  s.depth_weight = disparity.weight;
  s.free_space_surface = disparity.surface;
  s.terms = std::move(o.terms);
  s.loss = o.total;
}

// The step's stratified jitter [R, S] and density noise [N, R * S] (N = s.nerfs), drawn on
// the device from the run's seed and the step (StepGraph::draws).
// With a slice, the draws of its rays of the whole step's [R_all, S] and [N, R_all S].
void draw_randomness(StepGraph& s, const TrainConfig& c, size_t R, size_t S, RaySlice slice) {
  s.draws = std::make_shared<DrawCounter>();
  RandomStream jitter{c.seed, kJitterStream, s.draws}, noise{c.seed, kNoiseStream, s.draws};
  if (slice.global_rays) {
    jitter.view_cols = noise.view_cols = R * S;
    jitter.global_cols = noise.global_cols = slice.global_rays * S;
    jitter.col_offset = noise.col_offset = slice.first_ray * S;
  }
  s.jitter = random_uniform(s.graph, "jitter", Shape{R, S}, jitter);
  if (c.noise_std > 0)
    s.noise = random_normal(s.graph, "noise", Shape{static_cast<size_t>(s.nerfs), R * S}, noise, c.noise_std);
}

}  // namespace

std::vector<float> level_window(int levels, int features, double progress) {
  const double a = levels * std::clamp(progress, 0.0, 1.0);
  std::vector<float> w;
  for (int l = 0; l < levels; ++l) {
    const double x = l == 0 ? 1.0 : std::clamp(a - l, 0.0, 1.0);
    w.insert(w.end(), static_cast<size_t>(features), static_cast<float>((1.0 - std::cos(x * std::numbers::pi)) / 2.0));
  }
  return w;
}

bool disparity_usable(const RayGeometry& g) { return g.disparity && g.ndc; }

std::unique_ptr<StepGraph> build_pretrain_graph(const TrainConfig& c, const RayGeometry& geo, RaySlice slice) {
  auto s = std::make_unique<StepGraph>();
  Graph& g = s->graph;
  const size_t R = static_cast<size_t>(c.rays), S = static_cast<size_t>(c.samples);
  s->nerfs = 1;
  s->pixels = g.input("pixels", Shape{R, 2});
  s->cameras = g.input("cameras", Shape{1, kCameraFloats});
  draw_randomness(*s, c, R, S, slice);
  s->target_rgb = g.input("target_rgb", Shape{R, 3});
  Rays rays = generate_rays(s->pixels, s->cameras, {.ndc = geo.ndc});
  Samples smp = stratified_samples(rays, s->jitter, sample_options(c.samples, geo, {1}));
  s->pack_static = new_select(c.occupancy, {0});
  Tensor raw = static_raw(smp.positions[0], smp.viewdirs[0], scene_field(c.field, geo), s->pack_static);
  RenderOutputs out = render_composite(raw, smp.delta, smp.z, s->noise, pretrain_render_options(c.conventions));
  DisparityTargets disparity{&g, R, {}, {}, {}, {}};
  PriorWeights priors = prior_weights(c);
  priors.depth_scheduled = c.depth_ramp > 0;
  Objective o = pretrain_objective({out, raw, smp.delta, smp.z, s->noise}, s->target_rgb, priors,
                                   disparity_usable(geo) ? &disparity : nullptr, slice.ranks);
  s->psnr_mse = o.term("static_rgb");
  take_objective(*s, std::move(o), disparity);
  g.set_loss(s->loss);
  for (auto& [name, t] : s->terms) g.keep(t);
  return s;
}

std::unique_ptr<StepGraph> build_joint_graph(const TrainConfig& c, const RayGeometry& geo, RaySlice slice) {
  const int K = geo.num_objects;
  if (K < 1) throw Error("joint training needs at least one object NeRF", kExitInternal);
  auto s = std::make_unique<StepGraph>();
  Graph& g = s->graph;
  const size_t R = static_cast<size_t>(c.rays), S = static_cast<size_t>(c.samples);
  const size_t N = static_cast<size_t>(1 + K);
  s->nerfs = static_cast<int>(N);
  s->pixels = g.input("pixels", Shape{R, 2});
  s->cameras = g.input("cameras", Shape{N, kCameraFloats});
  draw_randomness(*s, c, R, S, slice);
  s->times = g.input("times", Shape{static_cast<size_t>(K), 1});
  s->target_rgb = g.input("target_rgb", Shape{R, 3});
  s->target_masks = g.input("target_masks", Shape{N, R});
  if (c.conventions.nerf_rgb_area && c.weights.nerf_rgb > 0.0f)
    s->target_nerf_rgb = g.input("target_nerf_rgb", Shape{N, R, 3});
  Rays rays = generate_rays(s->pixels, s->cameras, {.ndc = geo.ndc});
  const FieldConfig field = scene_field(c.field, geo);
  // Samples crowd about the objects where they stand at the step's times (read from the
  // motion on the device: the step needs nothing back from it).
  Tensor warp;
  if (uses_object_samples(c, geo, K)) {
    s->motion = motion_parameter(g, K, motion_options(geo).frames);
    Tensor radius = g.parameter(kObjectRadiusName, Shape{static_cast<size_t>(K)}, Init::zeros());
    warp = object_sample_warp(s->motion, radius, s->times, motion_options(geo),
                              static_cast<double>(c.object_samples) / c.samples, kObjectSampleRadii);
  }
  Samples smp = stratified_samples(rays, s->jitter, sample_options(c.samples, geo, {1, K}), warp);
  s->pack_static = new_select(c.occupancy, {0});
  s->pack_objects = new_select(c.occupancy, object_grids(K));
  Tensor raw_static = static_raw(smp.positions[0], smp.viewdirs[0], field, s->pack_static);
  if (c.static_background_only)
    raw_static = gradient_gate(raw_static, s->target_masks, 0,
                               c.static_blend_from_objects ? static_cast<size_t>(kRawBlend) : kRawChannels);
  if (field.motion == ObjectMotion::Rigid && !s->motion.valid())
    s->motion = motion_parameter(g, K, motion_options(geo).frames);
  if (field.motion == ObjectMotion::Rigid && field.encoding == Encoding::HashGrid && c.canonical_coarse_to_fine > 0)
    s->level_window = g.input("level_window", Shape{static_cast<size_t>(field.hash.outputs())});
  Tensor raw_objects = object_raw(smp.positions[1], s->times, field, geo, s->pack_objects, s->motion, s->level_window);
  Tensor raw = stack({raw_static, raw_objects});
  const RenderOptions ro = joint_render_options(c.conventions, c.weights);
  RenderOutputs out = render_composite(raw, smp.delta, smp.z, s->noise, ro);
  DisparityTargets disparity{&g, R, {}, {}, {}, {}};
  Objective o = joint_objective({out, raw, smp.delta, smp.z, s->noise},
                                {s->target_rgb, s->target_masks, s->target_nerf_rgb}, c.weights, ro, c.conventions,
                                prior_weights(c), disparity_usable(geo) ? &disparity : nullptr, s->motion,
                                s->motion.valid() ? motion_options(geo).frames : 0, slice.ranks);
  const Tensor full_rgb = o.term("full_rgb");
  take_objective(*s, std::move(o), disparity);
  // The progress PSNR is of the composite colour; without its loss term it is measured
  // separately (a forward-only mse nothing back-propagates through).
  s->psnr_mse = full_rgb.valid() ? full_rgb : mse(out.rgb, s->target_rgb);
  g.set_loss(s->loss);
  for (auto& [name, t] : s->terms) g.keep(t);
  g.keep(s->psnr_mse);
  return s;
}

}  // namespace nova

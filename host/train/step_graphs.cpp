#include "nova/train/step_graphs.hpp"

#include "nova/runtime/error.hpp"
#include "nova/loss/terms.hpp"
#include "nova/sampling/rigid_motion.hpp"
#include "nova/ops/tensor/tensor_ops.hpp"
#include "nova/sampling/rays.hpp"
#include "nova/render/render_composite.hpp"

namespace nova {
namespace {

// Streams of the step graphs' device draws (random.hpp).
constexpr uint32_t kJitterStream = 1, kNoiseStream = 2;

// The per-ray disparity inputs of the depth terms (created once).
void add_depth_inputs(StepGraph& s, const TrainConfig& c) {
  if (s.target_depth.valid()) return;
  const Shape rays{static_cast<size_t>(c.rays)};
  s.target_depth = s.graph.input("target_depth", rays);
  s.depth_valid = s.graph.input("depth_valid", rays);
}

// Adds w_depth * depth_loss(depth, -disparity) to `loss` when the scene supports it.
// With a slice, over the whole batch (its statistics summed over ranks).
Tensor with_depth_term(StepGraph& s, const TrainConfig& c, const RayGeometry& geo, Tensor depth,
                       Tensor loss, RaySlice slice) {
  if (!depth_term_active(c, geo)) return loss;
  add_depth_inputs(s, c);
  Tensor d = depth_loss(depth, s.target_depth, s.depth_valid, slice.ranks);
  s.terms.emplace_back("depth", d);
  return weighted_sum({loss, d}, {1.0f, c.w_depth});
}

// Adds w_free_space * free_space_loss of the object NeRFs on their masks' rays (joint
// training, scenes with disparity in NDC). With a slice, the disparity fit is the whole batch's.
Tensor with_free_space_term(StepGraph& s, const TrainConfig& c, const RayGeometry& geo,
                            Tensor raw, const Samples& smp, Tensor depth, Tensor loss, RaySlice slice) {
  if (c.w_free_space <= 0.0f || !disparity_usable(geo)) return loss;
  add_depth_inputs(s, c);
  Tensor f = free_space_loss(raw, smp.delta, smp.z, depth, s.target_depth, s.depth_valid,
                             s.target_masks, s.noise, c.free_space_margin, 1,
                             c.free_space_behind, slice.ranks);
  s.terms.emplace_back("free_space", f);
  return weighted_sum({loss, f}, {1.0f, c.w_free_space});
}

// Adds w_distortion * distortion_loss of the object NeRFs (NeRF 0 is the static one), each
// on its mask's rays, to `loss`. On the static NeRF the term cost 2 dB of camera-0 PSNR on
// the default synthetic scene (docs/accuracy.md), so it is not applied there.
Tensor with_distortion_term(StepGraph& s, const TrainConfig& c, Tensor raw, const Samples& smp,
                            Tensor masks, Tensor loss) {
  if (c.w_distortion <= 0.0f) return loss;
  Tensor d = distortion_loss(raw, smp.delta, smp.z, masks, s.noise, 1);
  s.terms.emplace_back("distortion", d);
  return weighted_sum({loss, d}, {1.0f, c.w_distortion});
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

bool disparity_usable(const RayGeometry& g) { return g.disparity && g.ndc; }

bool depth_term_active(const TrainConfig& c, const RayGeometry& g) {
  return c.w_depth > 0.0f && disparity_usable(g);
}

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
  Tensor rgb_loss = pretrain_rgb_loss(out.rgb, s->target_rgb);
  s->psnr_mse = rgb_loss;
  s->terms = {{"static_rgb", rgb_loss}};
  s->loss = with_depth_term(*s, c, geo, out.depth, rgb_loss, slice);
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
  Samples smp = stratified_samples(rays, s->jitter, sample_options(c.samples, geo, {1, K}));
  const FieldConfig field = scene_field(c.field, geo);
  s->pack_static = new_select(c.occupancy, {0});
  s->pack_objects = new_select(c.occupancy, object_grids(K));
  Tensor raw_static = static_raw(smp.positions[0], smp.viewdirs[0], field, s->pack_static);
  if (c.static_background_only) raw_static = gradient_gate(raw_static, s->target_masks, 0);
  if (field.motion == ObjectMotion::Rigid) s->motion = motion_parameter(g, K, motion_options(geo).frames);
  Tensor raw_objects = object_raw(smp.positions[1], s->times, field, geo, s->pack_objects, s->motion);
  Tensor raw = stack({raw_static, raw_objects});
  const RenderOptions ro = joint_render_options(c.conventions, c.weights);
  RenderOutputs out = render_composite(raw, smp.delta, smp.z, s->noise, ro);
  NovelViewLoss l = novel_view_loss(out, raw, smp.delta, s->noise,
                                    {s->target_rgb, s->target_masks, s->target_nerf_rgb}, c.weights,
                                    ro, c.conventions, slice.ranks);
  for (auto [name, t] : {std::pair<const char*, Tensor>{"full_rgb", l.full_rgb}, {"nerf_rgb", l.nerf_rgb},
                         {"mask", l.mask}, {"blending", l.blending}, {"alpha", l.alpha},
                         {"sparsity", l.sparsity}, {"order", l.order}})
    if (t.valid()) s->terms.emplace_back(name, t);
  s->loss = with_distortion_term(*s, c, raw, smp, s->target_masks,
                                 with_depth_term(*s, c, geo, out.depth, l.total, slice));
  s->loss = with_free_space_term(*s, c, geo, raw, smp, out.depth, s->loss, slice);
  if (s->motion.valid() && c.w_motion_smooth > 0.0f) {
    Tensor m = motion_smoothness(s->motion, motion_options(geo).frames);
    s->terms.emplace_back("motion_smooth", m);
    s->loss = weighted_sum({s->loss, m}, {1.0f, c.w_motion_smooth});
  }
  // The progress PSNR is of the composite colour; without its loss term it is measured
  // separately (a forward-only mse nothing back-propagates through).
  s->psnr_mse = l.full_rgb.valid() ? l.full_rgb : mse(out.rgb, s->target_rgb);
  g.set_loss(s->loss);
  for (auto& [name, t] : s->terms) g.keep(t);
  g.keep(s->psnr_mse);
  return s;
}

}  // namespace nova

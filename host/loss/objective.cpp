// Assembles the weighted NOVA loss from its terms; a zero weight leaves its term out of the
// graph entirely, so it costs nothing and cannot produce a gradient.
#include "nova/loss/objective.hpp"
#include "nova/loss/terms.hpp"
#include "nova/ops/tensor/tensor_ops.hpp"
#include "nova/runtime/error.hpp"
#include "nova/sampling/rigid_motion.hpp"

namespace nova {

NovelViewLoss novel_view_loss(const RenderOutputs& rendered, Tensor raw, Tensor delta,
                              Tensor noise, const NovelViewTargets& targets,
                              const NovelViewLossWeights& w, const RenderOptions& options,
                              const LossConventions& cv, GradientReducer* ranks) {
  NovelViewLoss l;
  std::vector<Tensor> terms;
  std::vector<float> weights;
  const auto add = [&](Tensor& slot, float weight, auto build) {
    if (weight == 0.0f) return;
    slot = build();
    terms.push_back(slot);
    weights.push_back(weight);
  };
  add(l.full_rgb, w.full_rgb, [&] { return mse(rendered.rgb, targets.rgb); });
  add(l.nerf_rgb, w.nerf_rgb, [&] {
    if (!cv.nerf_rgb_area) return masked_mse(rendered.nerf_rgb, targets.rgb, targets.masks);
    const Tensor target = targets.nerf_rgb.valid() ? targets.nerf_rgb : targets.rgb;
    return masked_mse_area(rendered.nerf_rgb, target, targets.masks, ranks);
  });
  add(l.mask, w.mask, [&] {
    return cv.mask_l1 ? mask_l1_loss(rendered.mask, targets.masks) : mse(rendered.mask, targets.masks);
  });
  add(l.blending, w.blending, [&] { return blending_loss(raw, options.blend_sigmoid); });
  // Without an object NeRF there is nothing to push outside a mask.
  const size_t nerfs = rendered.mask.shape()[0];
  add(l.alpha, nerfs > 1 ? w.alpha : 0.0f, [&] {
    return cv.alpha_outside ? alpha_loss_outside(raw, delta, targets.masks, noise, options.blend_sigmoid, ranks)
                            : alpha_loss(raw, delta, targets.masks, noise, options.blend_sigmoid);
  });
  add(l.sparsity, nerfs > 1 ? w.sparsity : 0.0f,
      [&] { return sparsity_loss(raw, delta, targets.masks, noise); });
  add(l.order, nerfs > 1 ? w.order : 0.0f, [&] {
    if (!rendered.nerf_depth.valid())
      throw Error("novel_view_loss: the order loss needs nerf_depth (RenderOptions::nerf_depth)",
                  kExitInternal);
    return order_loss(rendered.nerf_depth, targets.masks, ranks);
  });
  if (terms.empty()) throw Error("novel_view_loss: every loss weight is 0", kExitUsage);
  l.total = weighted_sum(terms, weights);
  return l;
}

LossConventions reference_conventions() {
  LossConventions c;
  c.mask_l1 = true;
  c.nerf_rgb_area = true;
  c.alpha_outside = true;
  c.mask_sum = true;
  c.blend_eps = 1e-8f;
  c.pretrain_plain = true;
  return c;
}

RenderOptions joint_render_options(const LossConventions& c, const NovelViewLossWeights& w) {
  RenderOptions o;
  o.blend_eps = c.blend_eps;
  o.alpha_full_sum = c.mask_sum;
  o.nerf_depth = w.order > 0.0f;
  return o;
}

RenderOptions pretrain_render_options(const LossConventions& c) {
  RenderOptions o;
  o.blend_eps = c.blend_eps;
  o.no_blend = c.pretrain_plain;
  return o;
}

Tensor pretrain_rgb_loss(Tensor rgb, Tensor target, Tensor background) {
  return background.valid() ? masked_mse(rgb, target, background) : mse(rgb, target);
}

void Objective::add(const std::string& name, Tensor term, float weight) {
  terms.emplace_back(name, term);
  total = weighted_sum({total, term}, {1.0f, weight});
}

Tensor Objective::term(const std::string& name) const {
  for (const auto& [n, t] : terms)
    if (n == name) return t;
  return {};
}

void DisparityTargets::make() {
  if (target.valid()) return;
  const Shape shape{rays};
  target = graph->input("target_depth", shape);
  valid = graph->input("depth_valid", shape);
}

namespace {

// w_depth * depth_loss(depth, -disparity); with `ranks`, over the whole batch (its statistics
// summed over ranks).
void add_depth_prior(Objective& o, const RenderedRays& r, const PriorWeights& p, DisparityTargets* disparity,
                     GradientReducer* ranks) {
  if (p.depth <= 0.0f || !disparity) return;
  disparity->make();
  const Tensor l = depth_loss(r.out.depth, disparity->target, disparity->valid, ranks);
  if (!p.depth_scheduled) return o.add("depth", l, p.depth);
  disparity->weight = disparity->graph->input("depth_weight", Shape{1});
  o.terms.emplace_back("depth", l);  // logged at full weight, trained at the step's share
  o.total = weighted_sum({o.total, scale_columns(l, disparity->weight)}, {1.0f, p.depth});
}

}  // namespace

Objective pretrain_objective(const RenderedRays& r, Tensor target_rgb, const PriorWeights& priors,
                             DisparityTargets* disparity, GradientReducer* ranks) {
  const Tensor rgb = pretrain_rgb_loss(r.out.rgb, target_rgb);
  Objective o{rgb, {{"static_rgb", rgb}}};
  add_depth_prior(o, r, priors, disparity, ranks);
  return o;
}

Objective joint_objective(const RenderedRays& r, const NovelViewTargets& targets, const NovelViewLossWeights& weights,
                          const RenderOptions& options, const LossConventions& conventions,
                          const PriorWeights& p, DisparityTargets* disparity, Tensor motion, int frames,
                          GradientReducer* ranks) {
  const NovelViewLoss l = novel_view_loss(r.out, r.raw, r.delta, r.noise, targets, weights, options, conventions, ranks);
  Objective o{l.total, {}};
  for (auto [name, t] : {std::pair<const char*, Tensor>{"full_rgb", l.full_rgb}, {"nerf_rgb", l.nerf_rgb},
                         {"mask", l.mask}, {"blending", l.blending}, {"alpha", l.alpha},
                         {"sparsity", l.sparsity}, {"order", l.order}})
    if (t.valid()) o.terms.emplace_back(name, t);
  add_depth_prior(o, r, p, disparity, ranks);
  if (p.distortion > 0.0f)
    o.add("distortion", distortion_loss(r.raw, r.delta, r.z, targets.masks, r.noise, 1), p.distortion);
  // With `ranks` the disparity fit is the whole batch's.
  if (p.free_space > 0.0f && disparity) {
    disparity->make();
    const bool given = p.free_space_surface_given;
    if (given) disparity->surface = disparity->graph->input("free_space_surface", Shape{disparity->rays});
    o.add("free_space",
          free_space_loss(r.raw, r.delta, r.z, r.out.depth, given ? disparity->surface : disparity->target,
                          disparity->valid, targets.masks, r.noise, p.free_space_margin, 1, p.free_space_behind,
                          ranks, !given),
          p.free_space);
  }
  if (motion.valid() && p.motion_smooth > 0.0f)
    o.add("motion_smooth", motion_smoothness(motion, frames), p.motion_smooth);
  return o;
}

}  // namespace nova

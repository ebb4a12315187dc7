#pragma once
// The training objective, assembled here alone: the NOVA loss of one render (the weighted sum
// of the loss terms of terms.hpp that a preset chooses, with the conventions of nova's own
// `quick` or of the public reference code; docs/training.md, "Loss conventions") and the
// priors on top of it (depth, free space, distortion, motion smoothness). A term of weight 0
// is not built at all.
#include <string>
#include <utility>
#include <vector>

#include "nova/graph/distributed.hpp"
#include "nova/graph/graph.hpp"
#include "nova/loss/terms.hpp"
#include "nova/render/render_composite.hpp"

namespace nova {

// The reference code's weights (docs/training.md).
struct NovelViewLossWeights {
  float full_rgb = 3.0f;  // mse(composite rgb, target rgb)
  float nerf_rgb = 1.0f;  // masked_mse(nerf_rgb, target rgb, masks): each NeRF in its region
  float mask = 0.1f;      // mse(M_n, masks): rendered per-NeRF masks against the masks
  float blending = 0.1f;  // blending_loss
  float alpha = 0.1f;     // alpha_loss (only built when there is an object NeRF)
  float sparsity = 0.0f;  // sparsity_loss (not in the reference; likewise objects only)
  float order = 0.0f;     // order_loss (the reference's 0.1; objects only; needs nerf_depth)
};

// How the terms are normalised and what the renderer gives them. The defaults are nova's
// own conventions (the quick preset); reference_conventions() gives the public reference
// code's (the reference preset). docs/training.md, "Loss conventions".
struct LossConventions {
  // Mask loss: mse(M, masks) over all N R values (false), or mask_l1_loss (true).
  bool mask_l1 = false;
  // Per-NeRF RGB loss: masked_mse over N R 3 with the one target colour (false), or
  // masked_mse_area, each NeRF against its own target (NovelViewTargets::nerf_rgb) (true).
  bool nerf_rgb_area = false;
  // Alpha loss: alpha_loss, weighted by 1 - mask over K R S (false), or alpha_loss_outside.
  bool alpha_outside = false;
  // M_n (and depth, acc): RenderOptions::alpha_full_sum.
  bool mask_sum = false;
  // RenderOptions::blend_eps.
  float blend_eps = 1e-6f;
  // Static pretraining rendered through the blend normalisation (false) or as a plain NeRF,
  // RenderOptions::no_blend (true).
  bool pretrain_plain = false;
};
LossConventions reference_conventions();

struct NovelViewTargets {
  Tensor rgb;    // [R, 3] target colour of the (possibly warped) view
  Tensor masks;  // [N, R] masks[0] = background (1 - union of objects), masks[n] = object n
  // [N, R, 3] each NeRF's own target colour (on augmented steps object n's own warped view):
  // read by the per-NeRF RGB loss under LossConventions::nerf_rgb_area; invalid: rgb for all.
  Tensor nerf_rgb{};
};

struct NovelViewLoss {
  Tensor total;  // scalar weighted sum of the present terms: pass to Graph::set_loss
  // Each term, unweighted (for logs); invalid (Tensor{}) when its weight is 0.
  Tensor full_rgb, nerf_rgb, mask, blending, alpha, sparsity, order;
};

// Builds the weighted loss of one render (raw/delta/noise/options: those given to
// render_composite) under `conventions`. Throws when every weight is 0, or when the order
// loss is weighted and `rendered` has no nerf_depth. With `ranks` of more than one rank
// (data-parallel training) the rays are this rank's share and the reference conventions'
// ratio terms divide by the whole batch's mask areas and counts (terms.hpp); the other terms
// are means over the rays, whose mean over ranks is already the whole batch's.
NovelViewLoss novel_view_loss(const RenderOutputs& rendered, Tensor raw, Tensor delta,
                              Tensor noise, const NovelViewTargets& targets,
                              const NovelViewLossWeights& weights = {},
                              const RenderOptions& options = {},
                              const LossConventions& conventions = {},
                              GradientReducer* ranks = nullptr);

// The render options of joint training under `conventions` (blend_eps, alpha_full_sum, and
// nerf_depth when `order` is weighted), and of static pretraining (blend_eps, no_blend).
RenderOptions joint_render_options(const LossConventions& conventions, const NovelViewLossWeights& w);
RenderOptions pretrain_render_options(const LossConventions& conventions);

// Pretraining of the static NeRF alone (rendered with N = 1): mse of its colour against the
// target, restricted to background pixels when `background` ([R], 1 = background) is given.
Tensor pretrain_rgb_loss(Tensor rgb, Tensor target, Tensor background = {});

// The objective grown term by term: each add puts weight * term on top of the total (one
// weighted_sum op) and keeps the term, unweighted and by name, for the progress lines and
// metrics.jsonl.
struct Objective {
  Tensor total;
  std::vector<std::pair<std::string, Tensor>> terms;
  void add(const std::string& name, Tensor term, float weight);
  // The term named `name`; invalid when it was not built.
  Tensor term(const std::string& name) const;
};

// The weights of the priors on top of the NOVA loss (`nova train`'s w-depth, w-free-space with
// free-space-margin and free-space-behind, w-distortion, w-motion-smooth).
struct PriorWeights {
  float depth = 0, free_space = 0, distortion = 0, motion_smooth = 0;
  float free_space_margin = 0.05f, free_space_behind = 0;
  // The depth term's weight is depth times a [1] data input (DisparityTargets::weight) set
  // every step: a schedule without rebuilding the graph.
  bool depth_scheduled = false;
  // The free-space loss's surface per ray is given (DisparityTargets::surface, in the rendered
  // depth's units) instead of fitted to the rendered depth over each batch.
  bool free_space_surface_given = false;
};

// The per-ray targets of the depth and free-space priors, inputs of `graph` made on first use
// (a graph without either prior has none): minus the disparity, and 1 where it applies.
struct DisparityTargets {
  Graph* graph = nullptr;
  size_t rays = 0;
  Tensor target, valid;
  Tensor weight;  // [1], with PriorWeights::depth_scheduled: the depth term's share this step
  Tensor surface;  // [R], with PriorWeights::free_space_surface_given: each ray's surface
  void make();
};

// A render as the objective reads it: render_composite's outputs and what it was given.
struct RenderedRays {
  RenderOutputs out;
  Tensor raw, delta, z, noise;
};

// Static pretraining: pretrain_rgb_loss ("static_rgb") and, where the scene's disparity is
// usable (`disparity` not null), the depth prior. With `ranks` the depth statistics are the
// whole batch's.
Objective pretrain_objective(const RenderedRays& r, Tensor target_rgb, const PriorWeights& priors,
                             DisparityTargets* disparity, GradientReducer* ranks = nullptr);

// Joint training: novel_view_loss, then the depth prior (with usable disparity), the
// distortion of each object NeRF on its mask's rays, the free-space prior (with usable
// disparity) and, for rigid objects (`motion` valid, `frames` per trajectory), the motion's
// smoothness. The distortion is not applied to the static NeRF: there it was tried at
// 0.01-0.1 on the default synthetic scene and not kept (docs/accuracy-studies.md, "Tried and
// not kept").
Objective joint_objective(const RenderedRays& r, const NovelViewTargets& targets, const NovelViewLossWeights& weights,
                          const RenderOptions& options, const LossConventions& conventions,
                          const PriorWeights& priors, DisparityTargets* disparity, Tensor motion, int frames,
                          GradientReducer* ranks = nullptr);

}  // namespace nova

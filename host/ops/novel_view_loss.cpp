// Assembles the weighted NOVA loss from its terms; a zero weight leaves its term out of the
// graph entirely, so it costs nothing and cannot produce a gradient.
#include "nova/losses.hpp"
#include "nova/ops.hpp"
#include "nova/error.hpp"

namespace nova {

NovelViewLoss novel_view_loss(const RenderOutputs& rendered, Tensor raw, Tensor delta,
                              Tensor noise, const NovelViewTargets& targets,
                              const NovelViewLossWeights& w, const RenderOptions& options) {
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
  add(l.nerf_rgb, w.nerf_rgb,
      [&] { return masked_mse(rendered.nerf_rgb, targets.rgb, targets.masks); });
  add(l.mask, w.mask, [&] { return mse(rendered.mask, targets.masks); });
  add(l.blending, w.blending, [&] { return blending_loss(raw, options.blend_sigmoid); });
  // Without an object NeRF there is nothing to push outside a mask.
  const size_t nerfs = rendered.mask.shape()[0];
  add(l.alpha, nerfs > 1 ? w.alpha : 0.0f,
      [&] { return alpha_loss(raw, delta, targets.masks, noise, options.blend_sigmoid); });
  add(l.sparsity, nerfs > 1 ? w.sparsity : 0.0f,
      [&] { return sparsity_loss(raw, delta, targets.masks, noise); });
  if (terms.empty()) throw Error("novel_view_loss: every loss weight is 0", kExitUsage);
  l.total = weighted_sum(terms, weights);
  return l;
}

Tensor pretrain_rgb_loss(Tensor rgb, Tensor target, Tensor background) {
  return background.valid() ? masked_mse(rgb, target, background) : mse(rgb, target);
}

}  // namespace nova

// The free-space loss (kernels/free_space_loss.cl): weight in front of the surface the disparity
// puts on each ray.
#include <cmath>

#include "nova/graph/executor.hpp"
#include "nova/loss/terms.hpp"
#include "loss/rank_moments.hpp"
#include "loss/ray_sample_layout.hpp"

namespace nova {
namespace {

// Inputs: raw, delta, z, depth, target, valid, masks[, noise][, first, second: the whole
// batch's moments of the fit (data-parallel training)].
class FreeSpaceLossOp final : public Op {
 public:
  FreeSpaceLossOp(detail::RaySampleLayout l, bool noise, float margin, float behind, bool moments, bool fitted)
      : l_(l), noise_(noise), margin_(margin), behind_(behind), moments_(moments), fitted_(fitted) {}
  std::string type() const override { return "free_space_loss"; }

  void forward(ExecContext& ctx) override {
    fit_disparity(ctx, l_.pairs());
    ctx.launch("free_space_loss", "free_space_partial")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(ctx.in(4)).arg(ctx.in(5))
        .arg(ctx.in(6)).arg(noise(ctx)).arg(ctx.workspace())
        .arg(detail::u32(l_.nerfs, "nerfs")).arg(detail::u32(l_.rays, "rays"))
        .arg(detail::u32(l_.samples, "samples")).arg(detail::u32(l_.channels, "channels"))
        .arg(l_.delta_stride()).arg(static_cast<int>(noise_)).arg(detail::u32(l_.first, "first NeRF"))
        .arg(margin_).arg(behind_).run(l_.pairs());
    ctx.launch("loss", "sum_finish").arg(ctx.workspace()).arg(ctx.out(0))
        .arg(detail::u32(l_.pairs(), "nerfs x rays")).arg(l_.pair_scale()).run(1);
  }

  void backward(ExecContext& ctx) override {
    cl_mem gl = ctx.grad_out(0), g = ctx.grad_in(0);
    if (!gl || !g) return;
    // The rendered depth only places the target (a constant): when it carries a gradient for
    // other consumers and this op writes it first, it must be cleared.
    cl_mem dp = ctx.grad_in(3);
    const bool clear_dp = dp && !ctx.accumulate_in(3);
    fit_disparity(ctx, l_.pairs() * l_.samples);
    ctx.launch("free_space_loss", "free_space_backward")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(ctx.in(4)).arg(ctx.in(5))
        .arg(ctx.in(6)).arg(noise(ctx)).arg(gl).arg(ctx.workspace()).arg(g)
        .arg(dp ? dp : g).arg(detail::u32(l_.nerfs, "nerfs")).arg(detail::u32(l_.rays, "rays"))
        .arg(detail::u32(l_.samples, "samples")).arg(detail::u32(l_.channels, "channels"))
        .arg(l_.delta_stride()).arg(static_cast<int>(noise_)).arg(detail::u32(l_.first, "first NeRF"))
        .arg(margin_).arg(behind_).arg(l_.pair_scale()).arg(static_cast<int>(ctx.accumulate_in(0)))
        .arg(static_cast<int>(clear_dp)).run(l_.pairs());
  }

  std::vector<TensorId> saved_for_backward() const override { return inputs(); }
  // Forward: the partial sums, then the fit; backward: the walk's T, then the fit.
  size_t workspace_bytes(Runtime&, Pass pass) const override {
    return ((pass == Pass::Forward ? l_.pairs() : l_.pairs() * l_.samples) + kFitFloats) * sizeof(float);
  }

 private:
  static constexpr size_t kFitFloats = 3;  // (a, b, n) of free_space_fit

  cl_mem noise(ExecContext& ctx) const { return noise_ ? ctx.in(7) : ctx.in(0); }

  // The disparity-to-depth fit of this pass, written after the first `at` floats of the
  // workspace (where the pass's kernel reads it).
  void fit_disparity(ExecContext& ctx, size_t at) const {
    if (!fitted_) {
      ctx.launch("free_space_loss", "free_space_fit_identity")
          .arg(ctx.workspace()).arg(detail::u32(at, "free-space workspace")).arg(detail::u32(l_.rays, "rays")).run(1);
      return;
    }
    if (moments_) {
      ctx.launch("rank_moments", "free_space_fit_from_moments")
          .arg(ctx.in(moments_at())).arg(ctx.in(moments_at() + 1)).arg(ctx.workspace())
          .arg(detail::u32(at, "free-space workspace")).run(1);
      return;
    }
    ctx.launch("free_space_loss", "free_space_fit")
        .arg(ctx.in(3)).arg(ctx.in(4)).arg(ctx.in(5)).arg(ctx.in(6)).arg(ctx.workspace())
        .arg(detail::u32(at, "free-space workspace")).arg(detail::u32(l_.rays, "rays")).run(1);
  }

  size_t moments_at() const { return noise_ ? 8 : 7; }

  detail::RaySampleLayout l_;
  bool noise_;
  float margin_, behind_;
  bool moments_;
  bool fitted_;
};

}  // namespace

Tensor free_space_loss(Tensor raw, Tensor delta, Tensor z, Tensor depth, Tensor target,
                       Tensor valid, Tensor masks, Tensor noise, float margin,
                       size_t first_nerf, float behind, GradientReducer* ranks, bool fitted) {
  const auto l = detail::ray_sample_layout("free_space_loss", raw, delta, z, noise, first_nerf);
  const auto bad = [](const std::string& what) { throw Error("free_space_loss: " + what, kExitInternal); };
  for (const Tensor& t : {depth, target, valid})
    if (!(t.shape() == Shape{l.rays}))
      bad(t.info().name + " must be [" + std::to_string(l.rays) + "], got " + t.shape().str());
  if (!(masks.shape() == Shape{l.nerfs, l.rays}))
    bad("masks must be [" + std::to_string(l.nerfs) + ", " + std::to_string(l.rays) + "], got " +
        masks.shape().str());
  if (!(margin >= 0.0f)) bad("margin must be >= 0");
  if (!(behind >= 0.0f) || !std::isfinite(behind)) bad("behind must be a finite number >= 0");
  for (const Tensor& t : {target, valid, masks})
    if (t.info().requires_grad) bad(t.info().name + " is data and cannot take a gradient");
  Graph& g = *raw.graph;
  Tensor y = g.activation(raw.info().name + ".free_space_loss", Shape{1});
  std::vector<Tensor> inputs = {raw, delta, z, depth, target, valid, masks};
  if (noise.valid()) inputs.push_back(noise);
  const bool split = fitted && ranks && ranks->size() > 1;
  if (split) {  // the fit's weights: valid rays of the background (masks row 0)
    // The fit is a constant, as the rendered depth it places: its moments take no gradient.
    const detail::BatchMoments m = detail::batch_moments(depth, target, valid, masks, *ranks, /*constant=*/true);
    inputs.push_back(m.first);
    inputs.push_back(m.second);
  }
  g.add(std::make_unique<FreeSpaceLossOp>(l, noise.valid(), margin, behind, split, fitted), inputs, {y});
  return y;
}

}  // namespace nova

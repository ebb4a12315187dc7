// The free-space loss (kernels/depth_loss.cl): weight in front of the surface the disparity
// puts on each ray.
#include <algorithm>

#include "nova/executor.hpp"
#include "nova/losses.hpp"
#include "nova/render.hpp"
#include "op_util.hpp"

namespace nova {
namespace {

// Inputs: raw, delta, z, depth, target, valid, masks[, noise].
class FreeSpaceLossOp final : public Op {
 public:
  FreeSpaceLossOp(size_t nerfs, size_t rays, size_t samples, size_t channels,
                  bool per_nerf_delta, bool noise, size_t first, float margin)
      : nerfs_(nerfs), rays_(rays), samples_(samples), channels_(channels),
        per_nerf_delta_(per_nerf_delta), noise_(noise), first_(first), margin_(margin) {}
  std::string type() const override { return "free_space_loss"; }

  void forward(ExecContext& ctx) override {
    ctx.launch("depth_loss", "free_space_partial")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(ctx.in(3)).arg(ctx.in(4))
        .arg(ctx.in(5)).arg(ctx.in(6)).arg(noise(ctx)).arg(ctx.workspace())
        .arg(detail::u32(nerfs_, "nerfs")).arg(detail::u32(rays_, "rays"))
        .arg(detail::u32(samples_, "samples")).arg(detail::u32(channels_, "channels"))
        .arg(delta_stride()).arg(static_cast<int>(noise_)).arg(detail::u32(first_, "first NeRF"))
        .arg(margin_).run(pairs());
    ctx.launch("loss", "sum_finish").arg(ctx.workspace()).arg(ctx.out(0))
        .arg(detail::u32(pairs(), "nerfs x rays")).arg(scale()).run(1);
  }

  void backward(ExecContext& ctx) override {
    cl_mem gl = ctx.grad_out(0), g = ctx.grad_in(0);
    if (!gl || !g) return;
    // The rendered depth only places the target (a constant): when it carries a gradient for
    // other consumers and this op writes it first, it must be cleared.
    cl_mem dp = ctx.grad_in(3);
    const bool clear_dp = dp && !ctx.accumulate_in(3);
    ctx.launch("depth_loss", "free_space_backward")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(ctx.in(3)).arg(ctx.in(4))
        .arg(ctx.in(5)).arg(ctx.in(6)).arg(noise(ctx)).arg(gl).arg(ctx.workspace()).arg(g)
        .arg(dp ? dp : g).arg(detail::u32(nerfs_, "nerfs")).arg(detail::u32(rays_, "rays"))
        .arg(detail::u32(samples_, "samples")).arg(detail::u32(channels_, "channels"))
        .arg(delta_stride()).arg(static_cast<int>(noise_)).arg(detail::u32(first_, "first NeRF"))
        .arg(margin_).arg(scale()).arg(static_cast<int>(ctx.accumulate_in(0)))
        .arg(static_cast<int>(clear_dp)).run(std::max(pairs(), rays_));
  }

  std::vector<TensorId> saved_for_backward() const override { return inputs(); }
  size_t workspace_bytes(Runtime&, Pass pass) const override {
    return (pass == Pass::Forward ? pairs() : pairs() * samples_) * sizeof(float);
  }

 private:
  cl_mem noise(ExecContext& ctx) const { return noise_ ? ctx.in(7) : ctx.in(0); }
  unsigned delta_stride() const {
    return per_nerf_delta_ ? detail::u32(rays_ * samples_, "rays x samples") : 0u;
  }
  size_t pairs() const { return nerfs_ * rays_; }
  // The mean over the (NeRF, ray) pairs taking part.
  float scale() const { return 1.0f / static_cast<float>((nerfs_ - first_) * rays_); }

  size_t nerfs_, rays_, samples_, channels_;
  bool per_nerf_delta_, noise_;
  size_t first_;
  float margin_;
};

[[noreturn]] void bad(const std::string& what) {
  throw Error("free_space_loss: " + what, kExitInternal);
}

}  // namespace

Tensor free_space_loss(Tensor raw, Tensor delta, Tensor z, Tensor depth, Tensor target,
                       Tensor valid, Tensor masks, Tensor noise, float margin,
                       size_t first_nerf) {
  const auto d = detail::as_batched(raw.shape(), "free_space_loss");
  if (first_nerf >= d.batch)
    bad("first NeRF " + std::to_string(first_nerf) + " leaves none of raw's " + std::to_string(d.batch));
  if (d.cols < static_cast<size_t>(kRawChannels))
    bad("raw needs at least 5 channels, got " + raw.shape().str());
  const Shape& zs = z.shape();
  if (zs.rank() != 2 || zs[0] * zs[1] != d.rows) bad("z must be [R, S] of raw's rows, got " + zs.str());
  const size_t rays = zs[0], samples = zs[1];
  const size_t dn = delta.shape().numel();
  if (dn != d.rows && dn != d.batch * d.rows) bad("delta " + delta.shape().str() + " does not fit raw");
  for (const Tensor& t : {depth, target, valid})
    if (!(t.shape() == Shape{rays})) bad(t.info().name + " must be [" + std::to_string(rays) + "], got " + t.shape().str());
  if (!(masks.shape() == Shape{d.batch, rays}))
    bad("masks must be [" + std::to_string(d.batch) + ", " + std::to_string(rays) + "], got " +
        masks.shape().str());
  if (noise.valid() && noise.shape().numel() != d.batch * d.rows)
    bad("noise " + noise.shape().str() + " does not fit raw");
  if (!(margin >= 0.0f)) bad("margin must be >= 0");
  for (const Tensor& t : {delta, z, target, valid, masks, noise})
    if (t.valid() && t.info().requires_grad) bad(t.info().name + " is data and cannot take a gradient");
  Graph& g = *raw.graph;
  Tensor y = g.activation(raw.info().name + ".free_space_loss", Shape{1});
  std::vector<Tensor> inputs = {raw, delta, z, depth, target, valid, masks};
  if (noise.valid()) inputs.push_back(noise);
  g.add(std::make_unique<FreeSpaceLossOp>(d.batch, rays, samples, d.cols, dn != d.rows,
                                          noise.valid(), first_nerf, margin),
        inputs, {y});
  return y;
}

}  // namespace nova

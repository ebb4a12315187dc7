// The distortion loss (kernels/distortion.cl): a ray's weight spread along its depth.
#include "nova/executor.hpp"
#include "nova/losses.hpp"
#include "nova/render.hpp"
#include "op_util.hpp"

namespace nova {
namespace {

class DistortionLossOp final : public Op {
 public:
  DistortionLossOp(size_t nerfs, size_t rays, size_t samples, size_t channels,
                   bool per_nerf_delta, bool noise, bool mask, size_t first)
      : nerfs_(nerfs), rays_(rays), samples_(samples), channels_(channels),
        per_nerf_delta_(per_nerf_delta), noise_(noise), mask_(mask), first_(first) {}
  std::string type() const override { return "distortion_loss"; }

  // Inputs: raw, delta, z[, masks][, noise]. Absent ones are passed as raw (never read).
  cl_mem mask(ExecContext& ctx) const { return mask_ ? ctx.in(3) : ctx.in(0); }
  cl_mem noise(ExecContext& ctx) const { return noise_ ? ctx.in(mask_ ? 4 : 3) : ctx.in(0); }
  unsigned delta_stride() const {
    return per_nerf_delta_ ? detail::u32(rays_ * samples_, "rays x samples") : 0u;
  }
  size_t pairs() const { return nerfs_ * rays_; }

  void forward(ExecContext& ctx) override {
    ctx.launch("distortion", "distortion_partial")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(noise(ctx)).arg(mask(ctx))
        .arg(ctx.workspace()).arg(detail::u32(nerfs_, "nerfs")).arg(detail::u32(rays_, "rays"))
        .arg(detail::u32(samples_, "samples")).arg(detail::u32(channels_, "channels"))
        .arg(delta_stride()).arg(static_cast<int>(noise_)).arg(static_cast<int>(mask_))
        .arg(detail::u32(first_, "first NeRF")).run(pairs());
    ctx.launch("loss", "sum_finish").arg(ctx.workspace()).arg(ctx.out(0))
        .arg(detail::u32(pairs(), "nerfs x rays")).arg(scale()).run(1);
  }

  void backward(ExecContext& ctx) override {
    cl_mem gl = ctx.grad_out(0), g = ctx.grad_in(0);
    if (!gl || !g) return;
    ctx.launch("distortion", "distortion_backward")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(noise(ctx)).arg(mask(ctx)).arg(gl)
        .arg(ctx.workspace()).arg(g).arg(detail::u32(nerfs_, "nerfs"))
        .arg(detail::u32(rays_, "rays")).arg(detail::u32(samples_, "samples"))
        .arg(detail::u32(channels_, "channels")).arg(delta_stride())
        .arg(static_cast<int>(noise_)).arg(static_cast<int>(mask_))
        .arg(detail::u32(first_, "first NeRF")).arg(scale())
        .arg(static_cast<int>(ctx.accumulate_in(0)))
        .run(pairs());
  }

  std::vector<TensorId> saved_for_backward() const override { return inputs(); }
  size_t workspace_bytes(Runtime&, Pass pass) const override {
    return (pass == Pass::Forward ? pairs() : 2 * pairs() * samples_) * sizeof(float);
  }

 private:
  // The mean over the (NeRF, ray) pairs taking part.
  float scale() const { return 1.0f / static_cast<float>((nerfs_ - first_) * rays_); }

  size_t nerfs_, rays_, samples_, channels_;
  bool per_nerf_delta_, noise_, mask_;
  size_t first_;
};

[[noreturn]] void bad(const std::string& what) {
  throw Error("distortion_loss: " + what, kExitInternal);
}

}  // namespace

Tensor distortion_loss(Tensor raw, Tensor delta, Tensor z, Tensor masks, Tensor noise,
                       size_t first_nerf) {
  const auto d = detail::as_batched(raw.shape(), "distortion_loss");
  if (first_nerf >= d.batch)
    bad("first NeRF " + std::to_string(first_nerf) + " leaves none of raw's " + std::to_string(d.batch));
  if (d.cols < static_cast<size_t>(kRawChannels))
    bad("raw needs at least 5 channels, got " + raw.shape().str());
  const Shape& zs = z.shape();
  if (zs.rank() != 2 || zs[0] * zs[1] != d.rows) bad("z must be [R, S] of raw's rows, got " + zs.str());
  const size_t rays = zs[0], samples = zs[1];
  const size_t dn = delta.shape().numel();
  if (dn != d.rows && dn != d.batch * d.rows) bad("delta " + delta.shape().str() + " does not fit raw");
  if (masks.valid() && !(masks.shape() == Shape{d.batch, rays}))
    bad("masks must be [" + std::to_string(d.batch) + ", " + std::to_string(rays) + "], got " +
        masks.shape().str());
  if (noise.valid() && noise.shape().numel() != d.batch * d.rows)
    bad("noise " + noise.shape().str() + " does not fit raw");
  for (const Tensor& t : {delta, z, masks, noise})
    if (t.valid() && t.info().requires_grad) bad(t.info().name + " is data and cannot take a gradient");
  Graph& g = *raw.graph;
  Tensor y = g.activation(raw.info().name + ".distortion_loss", Shape{1});
  std::vector<Tensor> inputs = {raw, delta, z};
  if (masks.valid()) inputs.push_back(masks);
  if (noise.valid()) inputs.push_back(noise);
  g.add(std::make_unique<DistortionLossOp>(d.batch, rays, samples, d.cols, dn != d.rows,
                                           noise.valid(), masks.valid(), first_nerf),
        inputs, {y});
  return y;
}

}  // namespace nova

// The distortion loss (kernels/distortion_loss.cl): a ray's weight spread along its depth.
#include "nova/graph/executor.hpp"
#include "nova/loss/terms.hpp"
#include "nova/render/render_composite.hpp"
#include "loss/ray_sample_layout.hpp"

namespace nova {
namespace {

class DistortionLossOp final : public Op {
 public:
  DistortionLossOp(detail::RaySampleLayout l, bool noise, bool mask) : l_(l), noise_(noise), mask_(mask) {}
  std::string type() const override { return "distortion_loss"; }

  // Inputs: raw, delta, z[, masks][, noise]. Absent ones are passed as raw (never read).
  cl_mem mask(ExecContext& ctx) const { return mask_ ? ctx.in(3) : ctx.in(0); }
  cl_mem noise(ExecContext& ctx) const { return noise_ ? ctx.in(mask_ ? 4 : 3) : ctx.in(0); }

  void forward(ExecContext& ctx) override {
    ctx.launch("distortion_loss", "distortion_partial")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(noise(ctx)).arg(mask(ctx))
        .arg(ctx.workspace()).arg(detail::u32(l_.nerfs, "nerfs")).arg(detail::u32(l_.rays, "rays"))
        .arg(detail::u32(l_.samples, "samples")).arg(detail::u32(l_.channels, "channels"))
        .arg(l_.delta_stride()).arg(static_cast<int>(noise_)).arg(static_cast<int>(mask_))
        .arg(detail::u32(l_.first, "first NeRF")).run(l_.pairs());
    ctx.launch("loss", "sum_finish").arg(ctx.workspace()).arg(ctx.out(0))
        .arg(detail::u32(l_.pairs(), "nerfs x rays")).arg(l_.pair_scale()).run(1);
  }

  void backward(ExecContext& ctx) override {
    cl_mem gl = ctx.grad_out(0), g = ctx.grad_in(0);
    if (!gl || !g) return;
    ctx.launch("distortion_loss", "distortion_backward")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(noise(ctx)).arg(mask(ctx)).arg(gl)
        .arg(ctx.workspace()).arg(g).arg(detail::u32(l_.nerfs, "nerfs"))
        .arg(detail::u32(l_.rays, "rays")).arg(detail::u32(l_.samples, "samples"))
        .arg(detail::u32(l_.channels, "channels")).arg(l_.delta_stride())
        .arg(static_cast<int>(noise_)).arg(static_cast<int>(mask_))
        .arg(detail::u32(l_.first, "first NeRF")).arg(l_.pair_scale())
        .arg(static_cast<int>(ctx.accumulate_in(0)))
        .run(l_.pairs());
  }

  std::vector<TensorId> saved_for_backward() const override { return inputs(); }
  size_t workspace_bytes(Runtime&, Pass pass) const override {
    return (pass == Pass::Forward ? l_.pairs() : 2 * l_.pairs() * l_.samples) * sizeof(float);
  }

 private:
  detail::RaySampleLayout l_;
  bool noise_, mask_;
};

}  // namespace

Tensor distortion_loss(Tensor raw, Tensor delta, Tensor z, Tensor masks, Tensor noise,
                       size_t first_nerf) {
  const auto l = detail::ray_sample_layout("distortion_loss", raw, delta, z, noise, first_nerf);
  if (masks.valid() && !(masks.shape() == Shape{l.nerfs, l.rays}))
    throw Error("distortion_loss: masks must be [" + std::to_string(l.nerfs) + ", " +
                    std::to_string(l.rays) + "], got " + masks.shape().str(),
                kExitInternal);
  if (masks.valid() && masks.info().requires_grad)
    throw Error("distortion_loss: masks are data and cannot take a gradient", kExitInternal);
  Graph& g = *raw.graph;
  Tensor y = g.activation(raw.info().name + ".distortion_loss", Shape{1});
  std::vector<Tensor> inputs = {raw, delta, z};
  if (masks.valid()) inputs.push_back(masks);
  if (noise.valid()) inputs.push_back(noise);
  g.add(std::make_unique<DistortionLossOp>(l, noise.valid(), masks.valid()), inputs, {y});
  return y;
}

}  // namespace nova

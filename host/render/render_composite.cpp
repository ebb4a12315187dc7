// The compositing render op: N NeRFs along shared samples, blended per sample (render.cl).
#include "nova/graph/executor.hpp"
#include "nova/render/render_composite.hpp"
#include "nova/tuning/tuning.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

class RenderCompositeOp final : public Op {
 public:
  RenderCompositeOp(size_t nerfs, size_t rays, size_t samples, size_t channels, bool per_nerf_delta,
                    bool noise, RenderOptions o)
      : nerfs_(nerfs), rays_(rays), samples_(samples), channels_(channels),
        per_nerf_delta_(per_nerf_delta), noise_(noise), o_(o) {}

  std::string type() const override { return "render_composite"; }

  std::string options() const { return render_program_options(nerfs_, o_); }

  void forward(ExecContext& ctx) override {
    ctx.launch("render", "render_forward", options())
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(noise_ ? ctx.in(3) : ctx.in(0))
        .arg(ctx.out(0)).arg(ctx.out(1)).arg(ctx.out(2)).arg(ctx.out(3)).arg(ctx.out(4))
        .arg(o_.nerf_depth ? ctx.out(5) : ctx.out(0))
        .arg(detail::u32(rays_, "rays")).arg(detail::u32(samples_, "samples"))
        .arg(detail::u32(channels_, "channels")).arg(delta_stride())
        .arg(static_cast<int>(noise_))
        .run(rays_);
  }

  void backward(ExecContext& ctx) override {
    cl_mem g_raw = ctx.grad_in(0);
    if (!g_raw) return;
    // Missing upstream gradients are zero: a flag per output, and any valid buffer in the
    // argument slot (the kernel never reads it).
    int mask = 0;
    cl_mem g[6];
    const size_t outputs = o_.nerf_depth ? 6 : 5;
    g[5] = ctx.in(0);
    for (size_t k = 0; k < outputs; ++k) {
      g[k] = ctx.grad_out(k);
      if (g[k]) mask |= 1 << k;
      else g[k] = ctx.in(0);
    }
    ctx.launch("render", "render_backward", options())
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(noise_ ? ctx.in(3) : ctx.in(0))
        .arg(g[0]).arg(g[1]).arg(g[2]).arg(g[3]).arg(g[4]).arg(g[5]).arg(g_raw).arg(ctx.workspace())
        .arg(detail::u32(rays_, "rays")).arg(detail::u32(samples_, "samples"))
        .arg(detail::u32(channels_, "channels")).arg(delta_stride())
        .arg(static_cast<int>(noise_)).arg(mask).arg(static_cast<int>(ctx.accumulate_in(0)))
        .run(rays_);
  }

  // The backward recomputes every per-sample term from the inputs: no output is kept.
  std::vector<TensorId> saved_for_backward() const override { return inputs(); }

  // Backward: the transmittances T_i and T^n_i of every sample.
  size_t workspace_bytes(Runtime&, Pass pass) const override {
    return pass == Pass::Backward ? (nerfs_ + 1) * rays_ * samples_ * sizeof(float) : 0;
  }

 private:
  unsigned delta_stride() const {
    return per_nerf_delta_ ? detail::u32(rays_ * samples_, "rays x samples") : 0u;
  }

  size_t nerfs_, rays_, samples_, channels_;
  bool per_nerf_delta_, noise_;
  RenderOptions o_;
};

[[noreturn]] void bad(const std::string& what) {
  throw Error("render_composite: " + what, kExitInternal);
}

}  // namespace

std::string render_program_options(size_t nerfs, const RenderOptions& o) {
  return RenderParams{nerfs, o.rgb_sigmoid, o.blend_sigmoid, o.hard_blend, o.blend_eps,
                      o.alpha_full_sum, o.no_blend, o.nerf_depth}
      .to_defines();
}

RenderOutputs render_composite(Tensor raw, Tensor delta, Tensor z, Tensor noise,
                               const RenderOptions& options) {
  const Shape& rs = raw.shape();
  if (rs.rank() != 2 && rs.rank() != 3) bad("raw must be [R*S, C] or [N, R*S, C], got " + rs.str());
  const size_t nerfs = rs.rank() == 3 ? rs[0] : 1;
  const size_t channels = rs.cols();
  const size_t rays_samples = rs.rank() == 3 ? rs[1] : rs[0];
  if (nerfs < 1 || nerfs > 16) bad("between 1 and 16 NeRFs are supported, got " + std::to_string(nerfs));
  if (channels < static_cast<size_t>(kRawChannels))
    bad("raw needs at least 5 channels (rgb, sigma, blend), got " + rs.str());
  if (z.shape().rank() != 2 || z.shape().numel() != rays_samples)
    bad("z must be [R, S] with R*S = " + std::to_string(rays_samples) + ", got " + z.shape().str());
  const size_t rays = z.shape()[0], samples = z.shape()[1];
  const size_t dn = delta.shape().numel();
  if (dn != rays_samples && dn != nerfs * rays_samples)
    bad("delta " + delta.shape().str() + " is neither [R, S] nor [N, R, S]");
  const bool has_noise = noise.valid();
  if (has_noise && noise.shape().numel() != nerfs * rays_samples)
    bad("noise " + noise.shape().str() + " must hold N*R*S values");
  for (const Tensor& t : {delta, z, noise})
    if (t.valid() && t.info().requires_grad) bad("'" + t.info().name + "' is data and cannot take a gradient");

  Graph& g = *raw.graph;
  const std::string base = raw.info().name;
  RenderOutputs o;
  o.rgb = g.activation(base + ".rgb", Shape{rays, 3});
  o.nerf_rgb = g.activation(base + ".nerf_rgb", Shape{nerfs, rays, 3});
  o.mask = g.activation(base + ".mask", Shape{nerfs, rays});
  o.depth = g.activation(base + ".depth", Shape{rays});
  o.acc = g.activation(base + ".acc", Shape{rays});
  std::vector<Tensor> outputs = {o.rgb, o.nerf_rgb, o.mask, o.depth, o.acc};
  if (options.nerf_depth) {
    o.nerf_depth = g.activation(base + ".nerf_depth", Shape{nerfs, rays});
    outputs.push_back(o.nerf_depth);
  }
  if (!(options.blend_eps > 0.0f) && !options.no_blend)
    bad("the blend epsilon must be positive, got " + std::to_string(options.blend_eps));
  std::vector<Tensor> inputs = {raw, delta, z};
  if (has_noise) inputs.push_back(noise);
  g.add(std::make_unique<RenderCompositeOp>(nerfs, rays, samples, channels,
                                            dn != rays_samples,
                                            has_noise, options),
        inputs, outputs);
  return o;
}

}  // namespace nova

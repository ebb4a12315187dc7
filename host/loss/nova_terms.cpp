// The novel-view loss ops: masked mse, blending loss, alpha loss (kernels in loss.cl). Each
// forward is a deterministic two-stage sum; each backward is elementwise.
#include "nova/graph/executor.hpp"
#include "nova/loss/terms.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

using detail::require_data;
using detail::bad_op;

void finish_sum(ExecContext& ctx, unsigned parts, float scale) {
  ctx.launch("loss", "sum_finish").arg(ctx.workspace()).arg(ctx.out(0)).arg(parts).arg(scale).run(1);
}

class MaskedMseOp final : public Op {
 public:
  MaskedMseOp(size_t groups, size_t rows, size_t cols)
      : n_(groups * rows * cols), rows_(rows), cols_(cols), parts_(detail::reduction_parts(n_)) {}
  std::string type() const override { return "masked_mse"; }

  void forward(ExecContext& ctx) override {
    const unsigned parts = detail::u32(parts_, "parts");
    ctx.launch("loss", "masked_sq_err_partial")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(ctx.workspace())
        .arg(detail::u32(n_, "size")).arg(detail::u32(rows_, "rows")).arg(detail::u32(cols_, "cols"))
        .arg(parts).run(parts_);
    finish_sum(ctx, parts, 1.0f / static_cast<float>(n_));
  }

  void backward(ExecContext& ctx) override {
    cl_mem gl = ctx.grad_out(0), g = ctx.grad_in(0);
    if (!gl || !g) return;
    ctx.launch("loss", "masked_sq_err_backward")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(gl).arg(g)
        .arg(detail::u32(n_, "size")).arg(detail::u32(rows_, "rows")).arg(detail::u32(cols_, "cols"))
        .arg(2.0f / static_cast<float>(n_)).arg(static_cast<int>(ctx.accumulate_in(0)))
        .run(n_);
  }

  std::vector<TensorId> saved_for_backward() const override { return inputs(); }
  size_t workspace_bytes(Runtime&, Pass pass) const override {
    return pass == Pass::Forward ? parts_ * sizeof(float) : 0;
  }

 private:
  size_t n_, rows_, cols_, parts_;
};

class BlendingLossOp final : public Op {
 public:
  BlendingLossOp(size_t nerfs, size_t samples, size_t channels, bool act)
      : nerfs_(nerfs), samples_(samples), channels_(channels), act_(act),
        parts_(detail::reduction_parts(samples)) {}
  std::string type() const override { return "blending_loss"; }

  void forward(ExecContext& ctx) override {
    const unsigned parts = detail::u32(parts_, "parts");
    ctx.launch("loss", "blend_sum_partial")
        .arg(ctx.in(0)).arg(ctx.workspace()).arg(detail::u32(nerfs_, "nerfs"))
        .arg(detail::u32(samples_, "samples")).arg(detail::u32(channels_, "channels"))
        .arg(static_cast<int>(act_)).arg(parts).run(parts_);
    finish_sum(ctx, parts, 1.0f / static_cast<float>(samples_));
  }

  void backward(ExecContext& ctx) override {
    cl_mem gl = ctx.grad_out(0), g = ctx.grad_in(0);
    if (!gl || !g) return;
    const size_t n = nerfs_ * samples_ * channels_;
    ctx.launch("loss", "blend_sum_backward")
        .arg(ctx.in(0)).arg(gl).arg(g).arg(detail::u32(nerfs_, "nerfs"))
        .arg(detail::u32(samples_, "samples")).arg(detail::u32(channels_, "channels"))
        .arg(static_cast<int>(act_)).arg(1.0f / static_cast<float>(samples_))
        .arg(static_cast<int>(ctx.accumulate_in(0)))
        .run(detail::u32(n, "raw size"));
  }

  std::vector<TensorId> saved_for_backward() const override { return inputs(); }
  size_t workspace_bytes(Runtime&, Pass pass) const override {
    return pass == Pass::Forward ? parts_ * sizeof(float) : 0;
  }

 private:
  size_t nerfs_, samples_, channels_;
  bool act_;
  size_t parts_;
};

class AlphaLossOp final : public Op {
 public:
  // (c_out, c_in) = (1, 0): the alpha loss; (0, 1): the sparsity loss (kernels/loss.cl).
  AlphaLossOp(size_t nerfs, size_t rays, size_t samples, size_t channels, bool per_nerf_delta,
              bool noise, bool act, float c_out, float c_in)
      : nerfs_(nerfs), rays_(rays), samples_(samples), channels_(channels),
        per_nerf_delta_(per_nerf_delta), noise_(noise), act_(act), c_out_(c_out), c_in_(c_in),
        parts_(detail::reduction_parts((nerfs - 1) * rays * samples)) {}
  std::string type() const override { return c_out_ != 0.0f ? "alpha_loss" : "sparsity_loss"; }

  unsigned delta_stride() const {
    return per_nerf_delta_ ? detail::u32(rays_ * samples_, "rays x samples") : 0u;
  }
  float scale() const { return 1.0f / static_cast<float>((nerfs_ - 1) * rays_ * samples_); }
  // Inputs: raw, delta, masks[, noise].
  cl_mem noise(ExecContext& ctx) const { return noise_ ? ctx.in(3) : ctx.in(0); }

  void forward(ExecContext& ctx) override {
    const unsigned parts = detail::u32(parts_, "parts");
    ctx.launch("loss", "alpha_outside_partial")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(noise(ctx)).arg(ctx.in(2)).arg(ctx.workspace())
        .arg(detail::u32(nerfs_, "nerfs")).arg(detail::u32(rays_, "rays"))
        .arg(detail::u32(samples_, "samples")).arg(detail::u32(channels_, "channels"))
        .arg(delta_stride()).arg(static_cast<int>(noise_)).arg(static_cast<int>(act_))
        .arg(c_out_).arg(c_in_).arg(parts)
        .run(parts_);
    finish_sum(ctx, parts, scale());
  }

  void backward(ExecContext& ctx) override {
    cl_mem gl = ctx.grad_out(0), g = ctx.grad_in(0);
    if (!gl || !g) return;
    const size_t n = nerfs_ * rays_ * samples_ * channels_;
    ctx.launch("loss", "alpha_outside_backward")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(noise(ctx)).arg(ctx.in(2)).arg(gl).arg(g)
        .arg(detail::u32(nerfs_, "nerfs")).arg(detail::u32(rays_, "rays"))
        .arg(detail::u32(samples_, "samples")).arg(detail::u32(channels_, "channels"))
        .arg(delta_stride()).arg(static_cast<int>(noise_)).arg(static_cast<int>(act_))
        .arg(c_out_).arg(c_in_).arg(scale()).arg(static_cast<int>(ctx.accumulate_in(0)))
        .run(detail::u32(n, "raw size"));
  }

  std::vector<TensorId> saved_for_backward() const override { return inputs(); }
  size_t workspace_bytes(Runtime&, Pass pass) const override {
    return pass == Pass::Forward ? parts_ * sizeof(float) : 0;
  }

 private:
  size_t nerfs_, rays_, samples_, channels_;
  bool per_nerf_delta_, noise_, act_;
  float c_out_, c_in_;
  size_t parts_;
};

// (N, M, C) of a raw [N, M, C] or [M, C] tensor.
detail::Matrix3 raw_dims(const Tensor& raw, const std::string& op) {
  const auto d = detail::as_batched(raw.shape(), op);
  if (d.cols < static_cast<size_t>(kRawChannels))
    bad_op(op, "raw needs at least 5 channels, got " + raw.shape().str());
  return d;
}

}  // namespace

Tensor masked_mse(Tensor pred, Tensor target, Tensor mask) {
  const std::string op = "masked_mse";
  const auto p = detail::as_batched(pred.shape(), op);
  if (target.shape().numel() != p.rows * p.cols || target.shape().cols() != p.cols)
    bad_op(op, "target " + target.shape().str() + " does not fit prediction " + pred.shape().str());
  if (mask.shape().numel() != p.batch * p.rows)
    bad_op(op, "mask " + mask.shape().str() + " does not fit prediction " + pred.shape().str());
  require_data(op, target);
  require_data(op, mask);
  Graph& g = *pred.graph;
  Tensor y = g.activation(pred.info().name + ".masked_mse", Shape{1});
  g.add(std::make_unique<MaskedMseOp>(p.batch, p.rows, p.cols), {pred, target, mask}, {y});
  return y;
}

Tensor blending_loss(Tensor raw, bool blend_sigmoid) {
  const auto d = raw_dims(raw, "blending_loss");
  Graph& g = *raw.graph;
  Tensor y = g.activation(raw.info().name + ".blending_loss", Shape{1});
  g.add(std::make_unique<BlendingLossOp>(d.batch, d.rows, d.cols, blend_sigmoid), {raw}, {y});
  return y;
}

namespace {

Tensor alpha_like_loss(const std::string& op, Tensor raw, Tensor delta, Tensor masks, Tensor noise,
                       bool blend_sigmoid, float c_out, float c_in) {
  const auto l = detail::alpha_loss_layout(op, raw, delta, masks, noise, kRawChannels);
  Graph& g = *raw.graph;
  Tensor y = g.activation(raw.info().name + "." + op, Shape{1});
  std::vector<Tensor> inputs = {raw, delta, masks};
  if (noise.valid()) inputs.push_back(noise);
  g.add(std::make_unique<AlphaLossOp>(l.nerfs, l.rays, l.samples, l.cols, l.per_nerf_delta,
                                      noise.valid(), blend_sigmoid, c_out, c_in),
        inputs, {y});
  return y;
}

}  // namespace

Tensor alpha_loss(Tensor raw, Tensor delta, Tensor masks, Tensor noise, bool blend_sigmoid) {
  return alpha_like_loss("alpha_loss", raw, delta, masks, noise, blend_sigmoid, 1.0f, 0.0f);
}

Tensor sparsity_loss(Tensor raw, Tensor delta, Tensor masks, Tensor noise) {
  return alpha_like_loss("sparsity_loss", raw, delta, masks, noise, true, 0.0f, 1.0f);
}

}  // namespace nova

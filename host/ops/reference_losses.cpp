// The novel-view loss terms as the public reference code normalises them (kernels/refloss.cl,
// LossConventions in novel_view_loss.hpp): per-NeRF L1 mask loss, per-NeRF masked RGB over the mask
// area, alpha loss over the rays outside each object's mask, and the order loss. Each forward
// is a deterministic two-stage sum; each backward recomputes the sums it divides by and is
// then elementwise.
#include "nova/executor.hpp"
#include "nova/losses.hpp"
#include "op_util.hpp"

namespace nova {
namespace {

[[noreturn]] void bad(const std::string& op, const std::string& what) {
  throw Error(op + ": " + what, kExitInternal);
}

void require_data(const std::string& op, const Tensor& t) {
  if (t.valid() && t.info().requires_grad)
    bad(op, "'" + t.info().name + "' is data and cannot take a gradient");
}

constexpr const char* kFamily = "refloss";

// A loss sum_g num_g / (den_g + eps) / c whose partial sums come from one kernel: the
// finish and the backward factors are shared (refloss.cl, "group ratio").
class GroupRatioOp : public Op {
 public:
  GroupRatioOp(size_t groups, size_t items, float c, float eps)
      : groups_(groups), parts_(detail::reduction_parts(items)), c_(c), eps_(eps) {}

  void forward(ExecContext& ctx) override {
    partials(ctx);
    ctx.launch(kFamily, "group_ratio_finish")
        .arg(ctx.workspace()).arg(ctx.out(0)).arg(u(groups_)).arg(u(parts_)).arg(c_).arg(eps_)
        .run(1);
  }

  void backward(ExecContext& ctx) override {
    if (!ctx.grad_out(0) || !ctx.grad_in(0)) return;
    partials(ctx);
    ctx.launch(kFamily, "group_ratio_factor")
        .arg(ctx.workspace()).arg(u(groups_)).arg(u(parts_)).arg(c_).arg(eps_)
        .run(groups_);
    elementwise_backward(ctx, u(2 * groups_ * parts_));
  }

  std::vector<TensorId> saved_for_backward() const override { return inputs(); }
  size_t workspace_bytes(Runtime&, Pass) const override {
    return (2 * groups_ * parts_ + groups_) * sizeof(float);
  }

 protected:
  static unsigned u(size_t v) { return detail::u32(v, "size"); }
  // Writes the 2 * groups * parts partial sums into the workspace.
  virtual void partials(ExecContext& ctx) = 0;
  virtual void elementwise_backward(ExecContext& ctx, unsigned factor_at) = 0;

  size_t groups_, parts_;
  float c_, eps_;
};

class MaskedMseAreaOp final : public GroupRatioOp {
 public:
  MaskedMseAreaOp(size_t groups, size_t rows, size_t cols, bool own_target)
      : GroupRatioOp(groups, rows, static_cast<float>(cols), 1e-8f), rows_(rows), cols_(cols),
        own_target_(own_target) {}
  std::string type() const override { return "masked_mse_area"; }

 private:
  unsigned stride() const { return own_target_ ? u(rows_ * cols_) : 0u; }
  void partials(ExecContext& ctx) override {
    ctx.launch(kFamily, "masked_sq_err_group_partial")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(ctx.workspace())
        .arg(u(groups_)).arg(u(rows_)).arg(u(cols_)).arg(stride()).arg(u(parts_))
        .run(groups_ * parts_);
  }
  void elementwise_backward(ExecContext& ctx, unsigned factor_at) override {
    ctx.launch(kFamily, "masked_sq_err_group_backward")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(ctx.workspace()).arg(factor_at)
        .arg(ctx.grad_out(0)).arg(ctx.grad_in(0)).arg(u(groups_)).arg(u(rows_)).arg(u(cols_))
        .arg(stride()).arg(static_cast<int>(ctx.accumulate_in(0)))
        .run(groups_ * rows_ * cols_);
  }
  size_t rows_, cols_;
  bool own_target_;
};

class AlphaOutsideOp final : public GroupRatioOp {
 public:
  // Inputs: raw, delta, masks[, noise]. Groups: the object NeRFs; c = S, eps = 0.
  AlphaOutsideOp(size_t nerfs, size_t rays, size_t samples, size_t channels, bool per_nerf_delta,
                 bool noise, bool act)
      : GroupRatioOp(nerfs - 1, rays, static_cast<float>(samples), 0.0f), nerfs_(nerfs),
        rays_(rays), samples_(samples), channels_(channels), per_nerf_delta_(per_nerf_delta),
        noise_(noise), act_(act) {}
  std::string type() const override { return "alpha_loss_outside"; }

 private:
  unsigned delta_stride() const { return per_nerf_delta_ ? u(rays_ * samples_) : 0u; }
  cl_mem noise(ExecContext& ctx) const { return noise_ ? ctx.in(3) : ctx.in(0); }
  void partials(ExecContext& ctx) override {
    ctx.launch(kFamily, "alpha_outside_group_partial")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(noise(ctx)).arg(ctx.in(2)).arg(ctx.workspace())
        .arg(u(nerfs_)).arg(u(rays_)).arg(u(samples_)).arg(u(channels_)).arg(delta_stride())
        .arg(static_cast<int>(noise_)).arg(static_cast<int>(act_)).arg(u(parts_))
        .run(groups_ * parts_);
  }
  void elementwise_backward(ExecContext& ctx, unsigned factor_at) override {
    ctx.launch(kFamily, "alpha_outside_group_backward")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(noise(ctx)).arg(ctx.in(2)).arg(ctx.workspace())
        .arg(factor_at).arg(ctx.grad_out(0)).arg(ctx.grad_in(0)).arg(u(nerfs_)).arg(u(rays_))
        .arg(u(samples_)).arg(u(channels_)).arg(delta_stride()).arg(static_cast<int>(noise_))
        .arg(static_cast<int>(act_)).arg(static_cast<int>(ctx.accumulate_in(0)))
        .run(nerfs_ * rays_ * samples_ * channels_);
  }
  size_t nerfs_, rays_, samples_, channels_;
  bool per_nerf_delta_, noise_, act_;
};

class OrderLossOp final : public GroupRatioOp {
 public:
  // One group; c = R (the reference divides by the depth map's last dimension), eps 1e-8.
  OrderLossOp(size_t nerfs, size_t rays)
      : GroupRatioOp(1, rays, static_cast<float>(rays), 1e-8f), nerfs_(nerfs), rays_(rays) {}
  std::string type() const override { return "order_loss"; }

 private:
  void partials(ExecContext& ctx) override {
    ctx.launch(kFamily, "order_partial")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.workspace()).arg(u(nerfs_)).arg(u(rays_))
        .arg(u(parts_))
        .run(parts_);
  }
  void elementwise_backward(ExecContext& ctx, unsigned factor_at) override {
    ctx.launch(kFamily, "order_backward")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.workspace()).arg(factor_at).arg(ctx.grad_out(0))
        .arg(ctx.grad_in(0)).arg(u(nerfs_)).arg(u(rays_))
        .arg(static_cast<int>(ctx.accumulate_in(0)))
        .run(nerfs_ * rays_);
  }
  size_t nerfs_, rays_;
};

class MaskL1Op final : public Op {
 public:
  MaskL1Op(size_t nerfs, size_t rays)
      : n_(nerfs * rays), rays_(rays), parts_(detail::reduction_parts(n_)) {}
  std::string type() const override { return "mask_l1"; }

  void forward(ExecContext& ctx) override {
    const unsigned parts = detail::u32(parts_, "parts");
    ctx.launch(kFamily, "abs_err_partial")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.workspace()).arg(detail::u32(n_, "size")).arg(parts)
        .run(parts_);
    ctx.launch(kFamily, "abs_err_finish")
        .arg(ctx.workspace()).arg(ctx.out(0)).arg(parts).arg(scale()).run(1);
  }

  void backward(ExecContext& ctx) override {
    cl_mem gl = ctx.grad_out(0), g = ctx.grad_in(0);
    if (!gl || !g) return;
    ctx.launch(kFamily, "abs_err_backward")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(gl).arg(g).arg(detail::u32(n_, "size")).arg(scale())
        .arg(static_cast<int>(ctx.accumulate_in(0)))
        .run(n_);
  }

  std::vector<TensorId> saved_for_backward() const override { return inputs(); }
  size_t workspace_bytes(Runtime&, Pass pass) const override {
    return pass == Pass::Forward ? parts_ * sizeof(float) : 0;
  }

 private:
  // sum over NeRFs of the mean over rays: 1 / R.
  float scale() const { return 1.0f / static_cast<float>(rays_); }
  size_t n_, rays_, parts_;
};

}  // namespace

Tensor mask_l1_loss(Tensor mask, Tensor target) {
  const std::string op = "mask_l1_loss";
  if (mask.shape().rank() != 2) bad(op, "mask must be [N, R], got " + mask.shape().str());
  if (target.shape() != mask.shape())
    bad(op, "target " + target.shape().str() + " does not match mask " + mask.shape().str());
  require_data(op, target);
  Graph& g = *mask.graph;
  Tensor y = g.activation(mask.info().name + "." + op, Shape{1});
  g.add(std::make_unique<MaskL1Op>(mask.shape()[0], mask.shape()[1]), {mask, target}, {y});
  return y;
}

Tensor masked_mse_area(Tensor pred, Tensor target, Tensor mask) {
  const std::string op = "masked_mse_area";
  const auto p = detail::as_batched(pred.shape(), op);
  const size_t tn = target.shape().numel();
  const bool own = tn == p.batch * p.rows * p.cols;
  if ((!own && tn != p.rows * p.cols) || target.shape().cols() != p.cols)
    bad(op, "target " + target.shape().str() + " does not fit prediction " + pred.shape().str());
  if (mask.shape().numel() != p.batch * p.rows)
    bad(op, "mask " + mask.shape().str() + " does not fit prediction " + pred.shape().str());
  require_data(op, target);
  require_data(op, mask);
  Graph& g = *pred.graph;
  Tensor y = g.activation(pred.info().name + "." + op, Shape{1});
  g.add(std::make_unique<MaskedMseAreaOp>(p.batch, p.rows, p.cols, own && p.batch > 1),
        {pred, target, mask}, {y});
  return y;
}

Tensor alpha_loss_outside(Tensor raw, Tensor delta, Tensor masks, Tensor noise, bool blend_sigmoid) {
  const std::string op = "alpha_loss_outside";
  const auto l = detail::alpha_loss_layout(op, raw, delta, masks, noise, kRawChannels);
  Graph& g = *raw.graph;
  Tensor y = g.activation(raw.info().name + "." + op, Shape{1});
  std::vector<Tensor> inputs = {raw, delta, masks};
  if (noise.valid()) inputs.push_back(noise);
  g.add(std::make_unique<AlphaOutsideOp>(l.nerfs, l.rays, l.samples, l.cols, l.per_nerf_delta,
                                         noise.valid(), blend_sigmoid),
        inputs, {y});
  return y;
}

Tensor order_loss(Tensor nerf_depth, Tensor masks) {
  const std::string op = "order_loss";
  const Shape& s = nerf_depth.shape();
  if (s.rank() != 2 || s[0] < 2) bad(op, "depth must be [N, R] with N >= 2, got " + s.str());
  if (masks.shape() != s) bad(op, "masks " + masks.shape().str() + " do not match depth " + s.str());
  require_data(op, masks);
  Graph& g = *nerf_depth.graph;
  Tensor y = g.activation(nerf_depth.info().name + "." + op, Shape{1});
  g.add(std::make_unique<OrderLossOp>(s[0], s[1]), {nerf_depth, masks}, {y});
  return y;
}

}  // namespace nova

// The novel-view loss terms as the public reference code normalises them (kernels/reference_terms.cl,
// LossConventions in novel_view_loss.hpp): per-NeRF L1 mask loss, per-NeRF masked RGB over the mask
// area, alpha loss over the rays outside each object's mask, and the order loss. Each forward
// is a deterministic two-stage sum; each backward recomputes the sums it divides by and is
// then elementwise. Split over ranks (data-parallel training) the same ops give a rank's sums
// instead, summed over ranks by rank_sum and finished by GroupRatioOfSumsOp, so the
// denominators (mask areas and counts) are the whole batch's.
#include "nova/graph/executor.hpp"
#include "nova/loss/terms.hpp"
#include "nova/ops/tensor/rank_sum.hpp"
#include "loss/group_ratio.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

using detail::require_data;
using detail::bad_op;

constexpr const char* kFamily = "reference_terms";

// A loss sum_g num_g / (den_g + eps) / c whose partial sums come from one kernel: the
// finish and the backward factors are shared (reference_terms.cl, "group ratio"). With `sums` the op
// stops at the sums: its output is [2 groups], (num_g, den_g) per group.
class GroupRatioOp : public Op {
 public:
  GroupRatioOp(size_t groups, size_t items, float c, float eps, bool sums)
      : groups_(groups), parts_(detail::reduction_parts(items)), c_(c), eps_(eps), sums_(sums) {}

  void forward(ExecContext& ctx) override {
    partials(ctx);
    if (sums_) {
      ctx.launch(kFamily, "group_sums_finish")
          .arg(ctx.workspace()).arg(ctx.out(0)).arg(u(groups_)).arg(u(parts_))
          .run(2 * groups_);
      return;
    }
    ctx.launch(kFamily, "group_ratio_finish")
        .arg(ctx.workspace()).arg(ctx.out(0)).arg(u(groups_)).arg(u(parts_)).arg(c_).arg(eps_)
        .run(1);
  }

  void backward(ExecContext& ctx) override {
    if (!ctx.grad_out(0) || !ctx.grad_in(0)) return;
    if (sums_) {  // the factors are the sums' gradients; no partial sums needed
      ctx.launch(kFamily, "group_sums_factor")
          .arg(ctx.grad_out(0)).arg(ctx.workspace()).arg(u(groups_))
          .run(groups_);
      elementwise_backward(ctx, ctx.workspace(), 1);
      return;
    }
    partials(ctx);
    ctx.launch(kFamily, "group_ratio_factor")
        .arg(ctx.workspace()).arg(u(groups_)).arg(u(parts_)).arg(c_).arg(eps_)
        .run(groups_);
    elementwise_backward(ctx, ctx.grad_out(0), u(2 * groups_ * parts_));
  }

  std::vector<TensorId> saved_for_backward() const override { return inputs(); }
  size_t workspace_bytes(Runtime&, Pass) const override {
    return (2 * groups_ * parts_ + groups_) * sizeof(float);
  }

 protected:
  static unsigned u(size_t v) { return detail::u32(v, "size"); }
  // Writes the 2 * groups * parts partial sums into the workspace.
  virtual void partials(ExecContext& ctx) = 0;
  // d loss / d input = gloss[0] workspace[factor_at + g] d num_g / d input.
  virtual void elementwise_backward(ExecContext& ctx, cl_mem gloss, unsigned factor_at) = 0;

  size_t groups_, parts_;
  float c_, eps_;
  bool sums_;
};

// The loss of GroupRatioOp from its sums [2 groups] (the whole batch's, summed over ranks).
class GroupRatioOfSumsOp final : public Op {
 public:
  GroupRatioOfSumsOp(size_t groups, float c, float eps) : groups_(groups), c_(c), eps_(eps) {}
  std::string type() const override { return "group_ratio"; }

  void forward(ExecContext& ctx) override {
    ctx.launch(kFamily, "group_ratio_finish")
        .arg(ctx.in(0)).arg(ctx.out(0)).arg(u(groups_)).arg(1u).arg(c_).arg(eps_)
        .run(1);
  }

  void backward(ExecContext& ctx) override {
    if (!ctx.grad_out(0) || !ctx.grad_in(0)) return;
    ctx.launch(kFamily, "group_ratio_backward")
        .arg(ctx.in(0)).arg(ctx.grad_out(0)).arg(ctx.grad_in(0)).arg(u(groups_)).arg(c_).arg(eps_)
        .arg(static_cast<int>(ctx.accumulate_in(0)))
        .run(2 * groups_);
  }

  std::vector<TensorId> saved_for_backward() const override { return inputs(); }

 private:
  static unsigned u(size_t v) { return detail::u32(v, "size"); }
  size_t groups_;
  float c_, eps_;
};

class MaskedMseAreaOp final : public GroupRatioOp {
 public:
  MaskedMseAreaOp(size_t groups, size_t rows, size_t cols, bool own_target, bool sums)
      : GroupRatioOp(groups, rows, static_cast<float>(cols), 1e-8f, sums), rows_(rows), cols_(cols),
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
  void elementwise_backward(ExecContext& ctx, cl_mem gloss, unsigned factor_at) override {
    ctx.launch(kFamily, "masked_sq_err_group_backward")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(ctx.workspace()).arg(factor_at)
        .arg(gloss).arg(ctx.grad_in(0)).arg(u(groups_)).arg(u(rows_)).arg(u(cols_))
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
                 bool noise, bool act, bool sums)
      : GroupRatioOp(nerfs - 1, rays, static_cast<float>(samples), 0.0f, sums), nerfs_(nerfs),
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
  void elementwise_backward(ExecContext& ctx, cl_mem gloss, unsigned factor_at) override {
    ctx.launch(kFamily, "alpha_outside_group_backward")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(noise(ctx)).arg(ctx.in(2)).arg(ctx.workspace())
        .arg(factor_at).arg(gloss).arg(ctx.grad_in(0)).arg(u(nerfs_)).arg(u(rays_))
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
  OrderLossOp(size_t nerfs, size_t rays, bool sums)
      : GroupRatioOp(1, rays, static_cast<float>(rays), 1e-8f, sums), nerfs_(nerfs), rays_(rays) {}
  std::string type() const override { return "order_loss"; }

 private:
  void partials(ExecContext& ctx) override {
    ctx.launch(kFamily, "order_partial")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.workspace()).arg(u(nerfs_)).arg(u(rays_))
        .arg(u(parts_))
        .run(parts_);
  }
  void elementwise_backward(ExecContext& ctx, cl_mem gloss, unsigned factor_at) override {
    ctx.launch(kFamily, "order_backward")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.workspace()).arg(factor_at).arg(gloss)
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
    ctx.launch("loss", "sum_finish")
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

// The sums of one of the ratio losses (a rank's, `sums`) or the loss itself, on one graph.
Tensor add_ratio_op(Graph& g, const std::string& name, bool sums, size_t groups,
                    std::unique_ptr<Op> op, const std::vector<Tensor>& inputs) {
  Tensor y = g.activation(name + (sums ? ".sums" : ""), sums ? Shape{2 * groups} : Shape{1});
  g.add(std::move(op), inputs, {y});
  return y;
}

detail::GroupSums build_masked_mse_area(Tensor pred, Tensor target, Tensor mask, bool sums) {
  const std::string op = "masked_mse_area";
  const auto p = detail::as_batched(pred.shape(), op);
  const size_t tn = target.shape().numel();
  const bool own = tn == p.batch * p.rows * p.cols;
  if ((!own && tn != p.rows * p.cols) || target.shape().cols() != p.cols)
    bad_op(op, "target " + target.shape().str() + " does not fit prediction " + pred.shape().str());
  if (mask.shape().numel() != p.batch * p.rows)
    bad_op(op, "mask " + mask.shape().str() + " does not fit prediction " + pred.shape().str());
  require_data(op, target);
  require_data(op, mask);
  Tensor y = add_ratio_op(*pred.graph, pred.info().name + "." + op, sums, p.batch,
                          std::make_unique<MaskedMseAreaOp>(p.batch, p.rows, p.cols, own && p.batch > 1, sums),
                          {pred, target, mask});
  return {y, p.batch, static_cast<float>(p.cols), 1e-8f};
}

detail::GroupSums build_alpha_loss_outside(Tensor raw, Tensor delta, Tensor masks, Tensor noise,
                                           bool blend_sigmoid, bool sums) {
  const std::string op = "alpha_loss_outside";
  const auto l = detail::alpha_loss_layout(op, raw, delta, masks, noise, kRawChannels);
  std::vector<Tensor> inputs = {raw, delta, masks};
  if (noise.valid()) inputs.push_back(noise);
  Tensor y = add_ratio_op(*raw.graph, raw.info().name + "." + op, sums, l.nerfs - 1,
                          std::make_unique<AlphaOutsideOp>(l.nerfs, l.rays, l.samples, l.cols, l.per_nerf_delta,
                                                           noise.valid(), blend_sigmoid, sums),
                          inputs);
  return {y, l.nerfs - 1, static_cast<float>(l.samples), 0.0f};
}

detail::GroupSums build_order_loss(Tensor nerf_depth, Tensor masks, bool sums) {
  const std::string op = "order_loss";
  const Shape& s = nerf_depth.shape();
  if (s.rank() != 2 || s[0] < 2) bad_op(op, "depth must be [N, R] with N >= 2, got " + s.str());
  if (masks.shape() != s) bad_op(op, "masks " + masks.shape().str() + " do not match depth " + s.str());
  require_data(op, masks);
  Tensor y = add_ratio_op(*nerf_depth.graph, nerf_depth.info().name + "." + op, sums, 1,
                          std::make_unique<OrderLossOp>(s[0], s[1], sums), {nerf_depth, masks});
  return {y, 1, static_cast<float>(s[1]), 1e-8f};
}

bool split(const GradientReducer* ranks) { return ranks && ranks->size() > 1; }

// The whole batch's loss from a rank's sums: every rank's value is one process's.
Tensor over_ranks(detail::GroupSums s, GradientReducer& ranks) {
  s.sums = rank_sum(s.sums, ranks);
  return detail::group_ratio(s);
}

}  // namespace

Tensor mask_l1_loss(Tensor mask, Tensor target) {
  const std::string op = "mask_l1_loss";
  if (mask.shape().rank() != 2) bad_op(op, "mask must be [N, R], got " + mask.shape().str());
  if (target.shape() != mask.shape())
    bad_op(op, "target " + target.shape().str() + " does not match mask " + mask.shape().str());
  require_data(op, target);
  Graph& g = *mask.graph;
  Tensor y = g.activation(mask.info().name + "." + op, Shape{1});
  g.add(std::make_unique<MaskL1Op>(mask.shape()[0], mask.shape()[1]), {mask, target}, {y});
  return y;
}

namespace detail {

GroupSums masked_mse_area_sums(Tensor pred, Tensor target, Tensor mask) {
  return build_masked_mse_area(pred, target, mask, true);
}

GroupSums alpha_loss_outside_sums(Tensor raw, Tensor delta, Tensor masks, Tensor noise, bool blend_sigmoid) {
  return build_alpha_loss_outside(raw, delta, masks, noise, blend_sigmoid, true);
}

GroupSums order_loss_sums(Tensor nerf_depth, Tensor masks) { return build_order_loss(nerf_depth, masks, true); }

Tensor group_ratio(const GroupSums& s) {
  if (s.sums.shape() != Shape{2 * s.groups})
    bad_op("group_ratio", "sums " + s.sums.shape().str() + " are not [2 x " + std::to_string(s.groups) + "]");
  Graph& g = *s.sums.graph;
  Tensor y = g.activation(s.sums.info().name + ".ratio", Shape{1});
  g.add(std::make_unique<GroupRatioOfSumsOp>(s.groups, s.c, s.eps), {s.sums}, {y});
  return y;
}

}  // namespace detail

Tensor masked_mse_area(Tensor pred, Tensor target, Tensor mask, GradientReducer* ranks) {
  if (split(ranks)) return over_ranks(build_masked_mse_area(pred, target, mask, true), *ranks);
  return build_masked_mse_area(pred, target, mask, false).sums;
}

Tensor alpha_loss_outside(Tensor raw, Tensor delta, Tensor masks, Tensor noise, bool blend_sigmoid,
                          GradientReducer* ranks) {
  if (split(ranks))
    return over_ranks(build_alpha_loss_outside(raw, delta, masks, noise, blend_sigmoid, true), *ranks);
  return build_alpha_loss_outside(raw, delta, masks, noise, blend_sigmoid, false).sums;
}

Tensor order_loss(Tensor nerf_depth, Tensor masks, GradientReducer* ranks) {
  if (!split(ranks)) return build_order_loss(nerf_depth, masks, false).sums;
  // c = R is the whole batch's rays: each rank holds the same share of them.
  detail::GroupSums s = build_order_loss(nerf_depth, masks, true);
  s.c *= static_cast<float>(ranks->size());
  return over_ranks(s, *ranks);
}

}  // namespace nova

// Batch statistics over every rank's rays (kernels/rank_moments.cl): the moment sums of a
// rank's rays, their sum over ranks (rank_sum), and the losses that normalise by them.
#include "nova/graph/executor.hpp"
#include "nova/loss/terms.hpp"
#include "nova/ops/tensor/rank_sum.hpp"
#include "loss/rank_moments.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

// Inputs: p, t, valid[, mask][, first]; output [3]. `constant`: p is treated as data (the
// sums take no gradient, so neither they nor their sum over ranks run a backward).
class MomentSumsOp final : public Op {
 public:
  MomentSumsOp(size_t rays, bool mask, bool centred, bool constant)
      : rays_(rays), mask_(mask), centred_(centred), constant_(constant) {}
  std::string type() const override { return centred_ ? "moment_sums_centred" : "moment_sums"; }
  bool differentiable_in(size_t) const override { return !constant_; }

  cl_mem mask(ExecContext& ctx) const { return mask_ ? ctx.in(3) : ctx.in(2); }
  size_t first_index() const { return mask_ ? 4 : 3; }
  cl_mem first(ExecContext& ctx) const { return centred_ ? ctx.in(first_index()) : ctx.in(0); }

  void forward(ExecContext& ctx) override {
    ctx.launch("rank_moments", "moment_sums")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(mask(ctx)).arg(first(ctx)).arg(ctx.out(0))
        .arg(detail::u32(rays_, "rays")).arg(static_cast<int>(mask_)).arg(static_cast<int>(centred_))
        .run(1);
  }

  void backward(ExecContext& ctx) override {
    cl_mem gy = ctx.grad_out(0), dp = ctx.grad_in(0);
    cl_mem dfirst = centred_ ? ctx.grad_in(first_index()) : nullptr;
    if (!dp && !dfirst) return;
    if (!gy) {  // a zero upstream gradient: zero contributions
      if (dp && !ctx.accumulate_in(0)) ctx.rt.fill_zero(dp, rays_ * sizeof(float));
      if (dfirst && !ctx.accumulate_in(first_index())) ctx.rt.fill_zero(dfirst, 3 * sizeof(float));
      return;
    }
    ctx.launch("rank_moments", "moment_sums_backward")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(mask(ctx)).arg(first(ctx)).arg(gy)
        .arg(dp ? dp : gy).arg(dfirst ? dfirst : gy).arg(detail::u32(rays_, "rays"))
        .arg(static_cast<int>(mask_)).arg(static_cast<int>(centred_))
        .arg(static_cast<int>(dp != nullptr)).arg(static_cast<int>(dp && ctx.accumulate_in(0)))
        .arg(static_cast<int>(dfirst != nullptr))
        .arg(static_cast<int>(dfirst && ctx.accumulate_in(first_index())))
        .run(1);
  }

  std::vector<TensorId> saved_for_backward() const override { return inputs(); }

 private:
  size_t rays_;
  bool mask_, centred_, constant_;
};

// Inputs: first, second (the whole batch's); output: the depth loss [1].
class DepthFromMomentsOp final : public Op {
 public:
  std::string type() const override { return "depth_loss_from_moments"; }

  void forward(ExecContext& ctx) override {
    ctx.launch("rank_moments", "depth_loss_from_moments").arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.out(0)).run(1);
  }

  void backward(ExecContext& ctx) override {
    cl_mem gl = ctx.grad_out(0), d0 = ctx.grad_in(0), d1 = ctx.grad_in(1);
    if (!d0 && !d1) return;
    if (!gl) {
      if (d0 && !ctx.accumulate_in(0)) ctx.rt.fill_zero(d0, 3 * sizeof(float));
      if (d1 && !ctx.accumulate_in(1)) ctx.rt.fill_zero(d1, 3 * sizeof(float));
      return;
    }
    ctx.launch("rank_moments", "depth_loss_from_moments_backward")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(gl).arg(d0 ? d0 : gl).arg(d1 ? d1 : gl)
        .arg(static_cast<int>(d0 != nullptr)).arg(static_cast<int>(d0 && ctx.accumulate_in(0)))
        .arg(static_cast<int>(d1 != nullptr)).arg(static_cast<int>(d1 && ctx.accumulate_in(1)))
        .run(1);
  }

  std::vector<TensorId> saved_for_backward() const override { return inputs(); }
};

Tensor moment_sums(Tensor p, Tensor t, Tensor valid, Tensor mask, Tensor first, bool constant) {
  Graph& g = *p.graph;
  Tensor y = g.activation(p.info().name + (first.valid() ? ".centred_moments" : ".moments"), Shape{3});
  std::vector<Tensor> in = {p, t, valid};
  if (mask.valid()) in.push_back(mask);
  if (first.valid()) in.push_back(first);
  g.add(std::make_unique<MomentSumsOp>(p.shape().numel(), mask.valid(), first.valid(), constant), in, {y});
  return y;
}

}  // namespace

namespace detail {

BatchMoments batch_moments(Tensor p, Tensor t, Tensor valid, Tensor mask, GradientReducer& ranks, bool constant) {
  BatchMoments m;
  m.first = rank_sum(moment_sums(p, t, valid, mask, Tensor{}, constant), ranks);
  m.second = rank_sum(moment_sums(p, t, valid, mask, m.first, constant), ranks);
  return m;
}

Tensor depth_loss_from_moments(const BatchMoments& m) {
  Graph& g = *m.first.graph;
  Tensor y = g.activation(m.first.info().name + ".depth_loss", Shape{1});
  g.add(std::make_unique<DepthFromMomentsOp>(), {m.first, m.second}, {y});
  return y;
}

}  // namespace detail
}  // namespace nova

// The sum over ranks (rank_sum.hpp): through the host, the reducer being a host interface.
#include "nova/ops/tensor/rank_sum.hpp"

#include "nova/runtime/error.hpp"
#include "nova/graph/executor.hpp"
#include "nova/runtime/runtime.hpp"

namespace nova {
namespace {

class RankSumOp final : public Op {
 public:
  RankSumOp(GradientReducer& ranks, size_t n) : ranks_(ranks), n_(n) {}
  std::string type() const override { return "rank_sum"; }

  void forward(ExecContext& ctx) override {
    std::vector<float> v(n_);
    ctx.rt.download(ctx.in(0), v.data(), n_ * sizeof(float));
    ranks_.sum(v);
    ctx.rt.upload(ctx.out(0), v.data(), n_ * sizeof(float));
  }

  // Every rank runs the same backward (the same graph), so each reaches the collective; a
  // missing upstream gradient counts as zero.
  void backward(ExecContext& ctx) override {
    cl_mem gy = ctx.grad_out(0), gx = ctx.grad_in(0);
    if (!gx) return;
    std::vector<float> v(n_, 0.0f);
    if (gy) ctx.rt.download(gy, v.data(), n_ * sizeof(float));
    ranks_.sum(v);
    if (ctx.accumulate_in(0)) {
      std::vector<float> had(n_);
      ctx.rt.download(gx, had.data(), n_ * sizeof(float));
      for (size_t i = 0; i < n_; ++i) v[i] = had[i] + v[i];
    }
    ctx.rt.upload(gx, v.data(), n_ * sizeof(float));
  }

  std::vector<TensorId> saved_for_backward() const override { return {}; }

 private:
  GradientReducer& ranks_;
  size_t n_;
};

}  // namespace

Tensor rank_sum(Tensor x, GradientReducer& ranks) {
  const size_t n = x.shape().numel();
  if (n == 0 || n > 4096)
    throw Error("rank_sum: " + x.info().name + " " + x.shape().str() + " is not a small tensor", kExitInternal);
  Graph& g = *x.graph;
  Tensor y = g.activation(x.info().name + ".rank_sum", x.shape());
  g.add(std::make_unique<RankSumOp>(ranks, n), {x}, {y});
  return y;
}

}  // namespace nova

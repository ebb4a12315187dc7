// y = x * w through the GEMM provider; several same-shaped networks as one batched GEMM.
#include <algorithm>

#include "nova/executor.hpp"
#include "nova/gemm.hpp"
#include "nova/ops.hpp"
#include "op_util.hpp"

namespace nova {
namespace {

class LinearOp final : public Op {
 public:
  LinearOp(size_t batch, size_t m, size_t k, size_t n) : b_(batch), m_(m), k_(k), n_(n) {}
  std::string type() const override { return "linear"; }

  // y = x w: [M, K] x [K, N].
  GemmArgs forward_args(cl_mem x, cl_mem w, cl_mem y) const {
    return {false, false, m_, n_, k_, 1.0f, x, k_, m_ * k_, w, n_, k_ * n_, 0.0f, y, n_, m_ * n_, b_};
  }
  // dx (+)= dy w^T: [M, N] x [N, K].
  GemmArgs dx_args(cl_mem dy, cl_mem w, cl_mem dx, bool acc) const {
    return {false, true, m_, k_, n_, 1.0f, dy, n_, m_ * n_, w, n_, k_ * n_, acc ? 1.0f : 0.0f,
            dx, k_, m_ * k_, b_};
  }
  // dw (+)= x^T dy: [K, M] x [M, N].
  GemmArgs dw_args(cl_mem x, cl_mem dy, cl_mem dw, bool acc) const {
    return {true, false, k_, n_, m_, 1.0f, x, k_, m_ * k_, dy, n_, m_ * n_, acc ? 1.0f : 0.0f,
            dw, n_, k_ * n_, b_};
  }

  void forward(ExecContext& ctx) override {
    gemm(ctx.rt, forward_args(ctx.in(0), ctx.in(1), ctx.out(0)), ctx.workspace());
  }

  void backward(ExecContext& ctx) override {
    cl_mem dy = ctx.grad_out(0);
    if (!dy) return;
    if (cl_mem dx = ctx.grad_in(0))
      gemm(ctx.rt, dx_args(dy, ctx.in(1), dx, ctx.accumulate_in(0)), ctx.workspace());
    if (cl_mem dw = ctx.grad_in(1))
      gemm(ctx.rt, dw_args(ctx.in(0), dy, dw, ctx.accumulate_in(1)), ctx.workspace());
  }

  // Backward needs x and w, never y.
  std::vector<TensorId> saved_for_backward() const override { return inputs(); }

  size_t workspace_bytes(Runtime& rt, Pass pass) const override {
    if (pass == Pass::Forward) return gemm_temp_bytes(rt, forward_args(nullptr, nullptr, nullptr));
    return std::max(gemm_temp_bytes(rt, dx_args(nullptr, nullptr, nullptr, false)),
                    gemm_temp_bytes(rt, dw_args(nullptr, nullptr, nullptr, false)));
  }

 private:
  size_t b_, m_, k_, n_;
};

}  // namespace

Tensor linear(Tensor x, Tensor w) {
  const auto xs = detail::as_batched(x.shape(), "linear");
  const auto ws = detail::as_batched(w.shape(), "linear");
  if (xs.batch != ws.batch || xs.cols != ws.rows || x.shape().rank() != w.shape().rank())
    throw Error("linear: input " + x.shape().str() + " does not fit weight " + w.shape().str(),
                kExitInternal);
  Graph& g = *x.graph;
  Shape ys = x.shape();
  ys.dims.back() = ws.cols;
  Tensor y = g.activation(x.info().name + ".lin", ys);
  g.add(std::make_unique<LinearOp>(xs.batch, xs.rows, xs.cols, ws.cols), {x, w}, {y});
  return y;
}

Tensor dense(Tensor x, Tensor w, Tensor b, Activation act) {
  return bias_act(linear(x, w), b, act);
}

}  // namespace nova

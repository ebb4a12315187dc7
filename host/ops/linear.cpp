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

  // m: the rows in use (packed samples run fewer than the capacity m_).
  // y = x w: [M, K] x [K, N].
  GemmArgs forward_args(cl_mem x, cl_mem w, cl_mem y, size_t m) const {
    return {false, false, m, n_, k_, 1.0f, x, k_, m * k_, w, n_, k_ * n_, 0.0f, y, n_, m * n_, b_};
  }
  // dx (+)= dy w^T: [M, N] x [N, K].
  GemmArgs dx_args(cl_mem dy, cl_mem w, cl_mem dx, bool acc, size_t m) const {
    return {false, true, m, k_, n_, 1.0f, dy, n_, m * n_, w, n_, k_ * n_, acc ? 1.0f : 0.0f,
            dx, k_, m * k_, b_};
  }
  // dw (+)= x^T dy: [K, M] x [M, N].
  GemmArgs dw_args(cl_mem x, cl_mem dy, cl_mem dw, bool acc, size_t m) const {
    return {true, false, k_, n_, m, 1.0f, x, k_, m * k_, dy, n_, m * n_, acc ? 1.0f : 0.0f,
            dw, n_, k_ * n_, b_};
  }

  void forward(ExecContext& ctx) override {
    const size_t m = ctx.in_rows(0, m_);
    if (m == 0) return;
    gemm(ctx.rt, forward_args(ctx.in(0), ctx.in(1), ctx.out(0), m), ctx.workspace());
  }

  void backward(ExecContext& ctx) override {
    cl_mem dy = ctx.grad_out(0);
    if (!dy) return;
    const size_t m = ctx.in_rows(0, m_);
    cl_mem dx = ctx.grad_in(0), dw = ctx.grad_in(1);
    if (m == 0) {  // no rows: the weight gradient is zero
      if (dw && !ctx.accumulate_in(1)) ctx.rt.fill_zero(dw, b_ * k_ * n_ * sizeof(float));
      return;
    }
    if (dx) gemm(ctx.rt, dx_args(dy, ctx.in(1), dx, ctx.accumulate_in(0), m), ctx.workspace());
    if (dw) gemm(ctx.rt, dw_args(ctx.in(0), dy, dw, ctx.accumulate_in(1), m), ctx.workspace());
  }

  // Backward needs x and w, never y.
  std::vector<TensorId> saved_for_backward() const override { return inputs(); }

  size_t workspace_bytes(Runtime& rt, Pass pass) const override {
    if (pass == Pass::Forward) return gemm_temp_bytes(rt, forward_args(nullptr, nullptr, nullptr, m_));
    return std::max(gemm_temp_bytes(rt, dx_args(nullptr, nullptr, nullptr, false, m_)),
                    gemm_temp_bytes(rt, dw_args(nullptr, nullptr, nullptr, false, m_)));
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

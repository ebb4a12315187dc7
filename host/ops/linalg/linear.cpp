// y = x * w through the GEMM provider; several same-shaped networks as one batched GEMM.
#include <algorithm>

#include "ops/linalg/layer_parts.hpp"

namespace nova {

namespace detail {

void LinearShape::backward(Runtime& rt, cl_mem x, cl_mem w, cl_mem dy, cl_mem dx_out,
                           bool acc_dx, cl_mem dw_out, bool acc_dw, size_t m,
                           cl_mem temp) const {
  if (m == 0) {  // no rows: the weight gradient is zero
    if (dw_out && !acc_dw) rt.fill_zero(dw_out, batch * k * n * sizeof(float));
    return;
  }
  if (dx_out) gemm(rt, dx(dy, w, dx_out, acc_dx, m), temp);
  if (dw_out) gemm(rt, dw(x, dy, dw_out, acc_dw, m), temp);
}

size_t LinearShape::backward_bytes(Runtime& rt, size_t m) const {
  return std::max(gemm_temp_bytes(rt, dx(nullptr, nullptr, nullptr, false, m)),
                  gemm_temp_bytes(rt, dw(nullptr, nullptr, nullptr, false, m)));
}

}  // namespace detail

namespace {

class LinearOp final : public Op {
 public:
  LinearOp(size_t batch, size_t m, size_t k, size_t n) : s_{batch, k, n}, m_(m) {}
  std::string type() const override { return "linear"; }

  void forward(ExecContext& ctx) override {
    const size_t m = ctx.in_rows(0, m_);
    if (m == 0) return;
    gemm(ctx.rt, s_.forward(ctx.in(0), ctx.in(1), ctx.out(0), m), ctx.workspace());
  }

  void backward(ExecContext& ctx) override {
    cl_mem dy = ctx.grad_out(0);
    if (!dy) return;
    s_.backward(ctx.rt, ctx.in(0), ctx.in(1), dy, ctx.grad_in(0), ctx.accumulate_in(0),
                ctx.grad_in(1), ctx.accumulate_in(1), ctx.in_rows(0, m_), ctx.workspace());
  }

  // Backward needs x and w, never y.
  std::vector<TensorId> saved_for_backward() const override { return inputs(); }

  size_t workspace_bytes(Runtime& rt, Pass pass) const override {
    if (pass == Pass::Forward) return gemm_temp_bytes(rt, s_.forward(nullptr, nullptr, nullptr, m_));
    return s_.backward_bytes(rt, m_);
  }

 private:
  detail::LinearShape s_;
  size_t m_;  // rows at capacity
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

}  // namespace nova

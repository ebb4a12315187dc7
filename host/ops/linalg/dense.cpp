// A dense layer, y = act(x w + b), as one op. Its forward writes y once where nova's own GEMM
// kernel is the tuned choice for the shape (bias and activation applied in the kernel's store:
// gemm.hpp's epilogue), applies them block by block behind the host BLAS (identity and ReLU)
// and runs CLBlast or the host BLAS + a bias_act pass otherwise; its backward is
// bias_act's then linear's, with dh = dy act'(y) written over dy, so the layer needs neither
// the pre-activation h nor a buffer for its gradient.
#include "ops/linalg/layer_parts.hpp"

namespace nova {
namespace {

class DenseOp final : public Op {
 public:
  DenseOp(size_t batch, size_t m, size_t k, size_t n, Activation act)
      : s_{batch, k, n}, m_(m), act_(act) {}
  std::string type() const override { return std::string("dense_") + activation_name(act_); }

  void forward(ExecContext& ctx) override {
    const size_t m = ctx.in_rows(0, m_);
    if (m == 0) return;
    gemm(ctx.rt, s_.forward(ctx.in(0), ctx.in(1), ctx.out(0), m), ctx.workspace(),
         GemmEpilogue{ctx.in(2), s_.n, act_});
  }

  // dy is the gradient of this op's own output: every consumer of y has added its part and
  // no one reads it after this backward, so it can hold dh. The bias gradient is taken from
  // dy before. For the identity dh = dy as it is.
  void backward(ExecContext& ctx) override {
    cl_mem dy = ctx.grad_out(0);
    if (!dy) return;
    const size_t m = ctx.in_rows(0, m_);
    cl_mem dx = ctx.grad_in(0), dw = ctx.grad_in(1);
    const bool wants_dh = (dx || dw) && act_ != Activation::Identity;
    detail::bias_act_backward(ctx, {s_.batch, m, s_.n}, act_, m_,
                              ctx.out(0), dy, wants_dh ? dy : nullptr, false, ctx.grad_in(2),
                              ctx.accumulate_in(2), ctx.workspace());
    s_.backward(ctx.rt, ctx.in(0), ctx.in(1), dy, dx, ctx.accumulate_in(0), dw,
                ctx.accumulate_in(1), m, ctx.workspace());
  }

  // x and w for the GEMMs, y for act'; neither b nor an h.
  std::vector<TensorId> saved_for_backward() const override {
    return {inputs()[0], inputs()[1], outputs()[0]};
  }

  size_t workspace_bytes(Runtime& rt, Pass pass) const override {
    if (pass == Pass::Forward)
      return gemm_temp_bytes(rt, s_.forward(nullptr, nullptr, nullptr, m_));
    return std::max(detail::bias_grad_workspace_floats(m_, s_.batch * s_.n) * sizeof(float),
                    s_.backward_bytes(rt, m_));
  }

 private:
  detail::LinearShape s_;
  size_t m_;  // rows at capacity
  Activation act_;
};

}  // namespace

Tensor dense(Tensor x, Tensor w, Tensor b, Activation act) {
  const auto xs = detail::as_batched(x.shape(), "dense");
  const auto ws = detail::as_batched(w.shape(), "dense");
  const bool batched = x.shape().rank() == 3;
  if (xs.batch != ws.batch || xs.cols != ws.rows || x.shape().rank() != w.shape().rank())
    throw Error("dense: input " + x.shape().str() + " does not fit weight " + w.shape().str(),
                kExitInternal);
  if (b.shape() != (batched ? Shape{ws.batch, ws.cols} : Shape{ws.cols}))
    throw Error("dense: bias " + b.shape().str() + " does not fit weight " + w.shape().str(),
                kExitInternal);
  Graph& g = *x.graph;
  Shape ys = x.shape();
  ys.dims.back() = ws.cols;
  Tensor y = g.activation(x.info().name + ".dense_" + activation_name(act), ys);
  g.add(std::make_unique<DenseOp>(xs.batch, xs.rows, xs.cols, ws.cols, act), {x, w, b}, {y});
  return y;
}

}  // namespace nova

// y = act(h + b): bias and activation fused into one pass over the GEMM output.
#include "nova/executor.hpp"
#include "nova/ops.hpp"
#include "op_util.hpp"

namespace nova {
namespace {

class BiasActOp final : public Op {
 public:
  BiasActOp(detail::Matrix3 s, Activation act) : s_(s), act_(act) {}
  std::string type() const override { return std::string("bias_") + activation_name(act_); }

  std::string options() const { return "-DACT=" + std::to_string(static_cast<int>(act_)); }
  size_t parts() const { return std::min<size_t>(64, std::max<size_t>(1, s_.rows / 64)); }

  void forward(ExecContext& ctx) override {
    const size_t rows = ctx.in_rows(0, s_.rows);
    const size_t n = s_.batch * rows * s_.cols;
    if (n == 0) return;
    ctx.launch("activation", "bias_act_forward", options())
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.out(0))
        .arg(detail::u32(n, "bias_act size")).arg(detail::u32(s_.cols, "cols"))
        .arg(detail::u32(rows * s_.cols, "per batch"))
        .run(n);
  }

  void backward(ExecContext& ctx) override {
    cl_mem dy = ctx.grad_out(0);
    if (!dy) return;
    const size_t rows = ctx.in_rows(0, s_.rows);
    const size_t n = s_.batch * rows * s_.cols;
    if (n > 0)
      if (cl_mem dh = ctx.grad_in(0))
      ctx.launch("activation", "bias_act_backward", options())
          .arg(ctx.out(0)).arg(dy).arg(dh).arg(detail::u32(n, "bias_act size"))
          .arg(static_cast<int>(ctx.accumulate_in(0)))
          .run(n);
    cl_mem db = ctx.grad_in(1);
    if (!db) return;
    const size_t bc = s_.batch * s_.cols;
    const unsigned parts = detail::u32(this->parts(), "parts");
    ctx.launch("activation", "bias_grad_partial", options())
        .arg(ctx.out(0)).arg(dy).arg(ctx.workspace()).arg(detail::u32(rows, "rows"))
        .arg(detail::u32(s_.cols, "cols")).arg(detail::u32(bc, "batch cols")).arg(parts)
        .run2(bc, parts);
    ctx.launch("reduce", "colsum_finish")
        .arg(ctx.workspace()).arg(db).arg(detail::u32(bc, "batch cols")).arg(parts)
        .arg(static_cast<int>(ctx.accumulate_in(1)))
        .run(bc);
  }

  // The derivative is computed from y; h is not needed.
  std::vector<TensorId> saved_for_backward() const override { return outputs(); }

  size_t workspace_bytes(Runtime&, Pass pass) const override {
    if (pass == Pass::Forward) return 0;
    return parts() * s_.batch * s_.cols * sizeof(float);
  }

 private:
  detail::Matrix3 s_;
  Activation act_;
};

}  // namespace

const char* activation_name(Activation a) {
  switch (a) {
    case Activation::ReLU: return "relu";
    case Activation::Sigmoid: return "sigmoid";
    case Activation::Softplus: return "softplus";
    default: return "identity";
  }
}

Tensor bias_act(Tensor h, Tensor b, Activation act) {
  const auto s = detail::as_batched(h.shape(), "bias_act");
  const bool ok = (h.shape().rank() == 2 && b.shape() == Shape{s.cols}) ||
                  (h.shape().rank() == 3 && b.shape() == Shape{s.batch, s.cols});
  if (!ok)
    throw Error("bias_act: bias " + b.shape().str() + " does not fit " + h.shape().str(),
                kExitInternal);
  Graph& g = *h.graph;
  Tensor y = g.activation(h.info().name + "." + activation_name(act), h.shape());
  g.add(std::make_unique<BiasActOp>(s, act), {h, b}, {y});
  return y;
}

}  // namespace nova

// repeat_rows (ops.hpp): a per-batch row spread over that batch's rows on the device.
#include "nova/graph/executor.hpp"
#include "nova/ops/tensor/tensor_ops.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

class RepeatRowsOp final : public Op {
 public:
  RepeatRowsOp(size_t batches, size_t rows, size_t cols) : batches_(batches), rows_(rows), cols_(cols) {}
  std::string type() const override { return "repeat_rows"; }

  void forward(ExecContext& ctx) override {
    ctx.launch("tensor", "repeat_rows")
        .arg(ctx.in(0)).arg(ctx.out(0)).arg(detail::u32(batches_, "batches"))
        .arg(detail::u32(rows_, "rows")).arg(detail::u32(cols_, "cols"))
        .run(batches_ * rows_ * cols_);
  }
  // Its input is data (times, constants): nothing upstream takes a gradient.
  void backward(ExecContext& ctx) override {
    if (ctx.grad_in(0)) throw Error("repeat_rows: no gradient to its input", kExitInternal);
  }
  std::vector<TensorId> saved_for_backward() const override { return {}; }

 private:
  size_t batches_, rows_, cols_;
};

}  // namespace

Tensor repeat_rows(Tensor x, size_t rows) {
  const Shape& s = x.shape();
  if (s.rank() != 2 || rows == 0)
    throw Error("repeat_rows: x must be [B, C] and rows >= 1, got " + s.str(), kExitInternal);
  if (x.info().requires_grad) throw Error("repeat_rows: x is data and cannot take a gradient", kExitInternal);
  Graph& g = *x.graph;
  const Shape out = s[0] == 1 ? Shape{rows, s[1]} : Shape{s[0], rows, s[1]};
  Tensor y = g.activation(x.info().name + ".repeated", out);
  g.add(std::make_unique<RepeatRowsOp>(s[0], rows, s[1]), {x}, {y});
  return y;
}

}  // namespace nova

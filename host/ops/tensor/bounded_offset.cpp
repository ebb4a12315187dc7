// A position moved by a bounded learned offset: y + bound tanh(raw). A rigid object's
// deformation field moves its canonical samples with it (TrainConfig::deform_width); the
// bound keeps the deformed shape near the rigid one, where the frames' views still agree.
#include "nova/graph/executor.hpp"
#include "nova/ops/tensor/tensor_ops.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

class BoundedOffsetOp final : public Op {
 public:
  BoundedOffsetOp(size_t rows, size_t cols, float bound) : rows_(rows), cols_(cols), bound_(bound) {}
  std::string type() const override { return "bounded_offset"; }

  void forward(ExecContext& ctx) override {
    const size_t n = ctx.in_rows(0, rows_) * cols_;
    if (n == 0) return;
    ctx.launch("tensor", "bounded_offset")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.out(0)).arg(detail::u32(n, "offset elements")).arg(bound_)
        .run(n);
  }

  void backward(ExecContext& ctx) override {
    cl_mem dout = ctx.grad_out(0), dy = ctx.grad_in(0), draw = ctx.grad_in(1);
    const size_t n = ctx.in_rows(0, rows_) * cols_;
    if (!dout || (!dy && !draw) || n == 0) return;
    // A missing gradient's slot gets dout, never written (its flag is 0).
    ctx.launch("tensor", "bounded_offset_back")
        .arg(ctx.in(1)).arg(dout).arg(dy ? dy : dout).arg(draw ? draw : dout)
        .arg(detail::u32(n, "offset elements")).arg(bound_)
        .arg(static_cast<int>(dy != nullptr)).arg(static_cast<int>(dy && ctx.accumulate_in(0)))
        .arg(static_cast<int>(draw != nullptr)).arg(static_cast<int>(draw && ctx.accumulate_in(1)))
        .run(n);
  }

  std::vector<TensorId> saved_for_backward() const override { return {inputs()[1]}; }

 private:
  size_t rows_, cols_;
  float bound_;
};

}  // namespace

Tensor bounded_offset(Tensor y, Tensor raw, float bound) {
  const Shape& s = y.shape();
  if (!(raw.shape() == s))
    throw Error("bounded_offset: raw " + raw.shape().str() + " must have the shape of y " + s.str(), kExitInternal);
  if (!(bound > 0.0f)) throw Error("bounded_offset: the bound must be > 0", kExitInternal);
  Graph& g = *y.graph;
  Tensor out = g.activation(y.info().name + ".offset", s);
  g.add(std::make_unique<BoundedOffsetOp>(s.rows(), s.cols(), bound), {y, raw}, {out});
  return out;
}

}  // namespace nova

// A gradient gate: the forward is the identity, the backward lets each group of rows' gradient
// through scaled by its gate (0 stops it, 1 passes it). Joint training gates the static
// NeRF's outputs with each ray's background mask, so that object pixels do not teach the
// static NeRF their colours (TrainConfig::static_background_only).
#include <algorithm>

#include "nova/graph/executor.hpp"
#include "nova/ops/tensor/tensor_ops.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

class GradientGateOp final : public Op {
 public:
  GradientGateOp(size_t rows, size_t cols, size_t group, size_t gate_offset, size_t gated)
      : rows_(rows), cols_(cols), group_(group), gate_offset_(gate_offset), gated_(gated) {}
  std::string type() const override { return "gradient_gate"; }

  void forward(ExecContext& ctx) override {
    const unsigned c = detail::u32(cols_, "gate columns");
    ctx.launch("tensor", "copy_cols")
        .arg(ctx.in(0)).arg(ctx.out(0)).arg(detail::u32(rows_, "gate rows")).arg(c).arg(c)
        .arg(0u).run2(cols_, rows_);
  }

  void backward(ExecContext& ctx) override {
    cl_mem dy = ctx.grad_out(0), dx = ctx.grad_in(0);
    if (!dy || !dx) return;
    ctx.launch("tensor", "gate_rows_back")
        .arg(dy).arg(ctx.in(1)).arg(dx).arg(detail::u32(rows_, "gate rows"))
        .arg(detail::u32(cols_, "gate columns")).arg(detail::u32(group_, "gate group"))
        .arg(detail::u32(gate_offset_, "gate offset")).arg(detail::u32(gated_, "gated columns"))
        .arg(static_cast<int>(ctx.accumulate_in(0))).run(rows_ * cols_);
  }

  std::vector<TensorId> saved_for_backward() const override { return {inputs()[1]}; }

 private:
  size_t rows_, cols_, group_, gate_offset_, gated_;
};

}  // namespace

Tensor gradient_gate(Tensor x, Tensor gate, size_t gate_row, size_t gated_cols) {
  const Shape& s = x.shape();
  const Shape& gs = gate.shape();
  if (s.rank() != 2 || gs.rank() != 2 || gate_row >= gs[0] || gs[1] == 0 || s[0] % gs[1] != 0)
    throw Error("gradient_gate: x " + s.str() + " must be [R * G, C] for gate " + gs.str() +
                    " = [rows, R] and gate row " + std::to_string(gate_row),
                kExitInternal);
  if (gate.info().requires_grad)
    throw Error("gradient_gate: the gate is data and cannot take a gradient", kExitInternal);
  Graph& g = *x.graph;
  Tensor y = g.activation(x.info().name + ".gated", s);
  g.add(std::make_unique<GradientGateOp>(s[0], s[1], s[0] / gs[1], gate_row * gs[1], std::min(gated_cols, s[1])),
        {x, gate}, {y});
  return y;
}

}  // namespace nova

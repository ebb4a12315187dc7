// Columns scaled by a data weight per column. Training opens a hash encoding's levels from
// coarse to fine with it (TrainConfig::canonical_coarse_to_fine): a learned motion then first
// aligns what the coarse levels see, where the loss is smooth in the motion.
#include "nova/graph/executor.hpp"
#include "nova/ops/tensor/tensor_ops.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

class ScaleColumnsOp final : public Op {
 public:
  ScaleColumnsOp(size_t rows, size_t cols) : rows_(rows), cols_(cols) {}
  std::string type() const override { return "scale_columns"; }

  void forward(ExecContext& ctx) override { run(ctx, ctx.in(0), ctx.out(0), false); }

  void backward(ExecContext& ctx) override {
    cl_mem dy = ctx.grad_out(0), dx = ctx.grad_in(0);
    if (dy && dx) run(ctx, dy, dx, ctx.accumulate_in(0));
  }

  std::vector<TensorId> saved_for_backward() const override { return {inputs()[1]}; }

 private:
  void run(ExecContext& ctx, cl_mem x, cl_mem y, bool accumulate) {
    const size_t rows = ctx.in_rows(0, rows_);
    if (rows == 0) return;
    ctx.launch("tensor", "scale_cols")
        .arg(x).arg(ctx.in(1)).arg(y).arg(detail::u32(rows, "scaled rows"))
        .arg(detail::u32(cols_, "scaled columns")).arg(static_cast<int>(accumulate))
        .run(rows * cols_);
  }

  size_t rows_, cols_;
};

}  // namespace

Tensor scale_columns(Tensor x, Tensor weights) {
  const Shape& s = x.shape();
  if (weights.shape().rank() != 1 || weights.shape()[0] != s.cols())
    throw Error("scale_columns: weights " + weights.shape().str() + " must be [" + std::to_string(s.cols()) +
                    "] for x " + s.str(),
                kExitInternal);
  detail::require_data("scale_columns", weights);
  Graph& g = *x.graph;
  Tensor y = g.activation(x.info().name + ".scaled", s);
  g.add(std::make_unique<ScaleColumnsOp>(s.rows(), s.cols()), {x, weights}, {y});
  return y;
}

}  // namespace nova

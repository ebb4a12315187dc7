// Positions into the coordinates of a box per network: (x - centre) exp(log_scale), per
// axis. A rigid object's canonical field encodes its own box this way, so its hash grid's
// cells are sized by the object, not by the scene (FieldConfig::object_box).
#include "nova/graph/executor.hpp"
#include "nova/ops/tensor/tensor_ops.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

class BoxCoordinatesOp final : public Op {
 public:
  BoxCoordinatesOp(size_t nets, size_t rows) : nets_(nets), rows_(rows) {}
  std::string type() const override { return "box_coordinates"; }

  void forward(ExecContext& ctx) override {
    const size_t rows = ctx.in_rows(0, rows_);
    if (rows == 0) return;
    launch(ctx, "box_coordinates", ctx.in(0), ctx.out(0), rows).run(nets_ * rows * 3);
  }

  void backward(ExecContext& ctx) override {
    cl_mem dy = ctx.grad_out(0), dx = ctx.grad_in(0);
    const size_t rows = ctx.in_rows(0, rows_);
    if (!dy || !dx || rows == 0) return;
    launch(ctx, "box_coordinates_back", dy, dx, rows).arg(static_cast<int>(ctx.accumulate_in(0))).run(nets_ * rows * 3);
  }

  std::vector<TensorId> saved_for_backward() const override { return {inputs()[1]}; }
  // The box is a constant of the run (set from the masks), never learned.
  bool differentiable_in(size_t index) const override { return index == 0; }

 private:
  // The arguments both kernels share: x (or dy), the box, the output, rows per box, elements.
  Launch launch(ExecContext& ctx, const char* kernel, cl_mem x, cl_mem y, size_t rows) const {
    return ctx.launch("tensor", kernel)
        .arg(x).arg(ctx.in(1)).arg(y).arg(detail::u32(rows, "box rows"))
        .arg(detail::u32(nets_ * rows * 3, "box elements"));
  }

  size_t nets_, rows_;
};

}  // namespace

Tensor box_coordinates(Tensor x, Tensor box) {
  const Shape& s = x.shape();
  const detail::Matrix3 m = detail::as_batched(s, "box_coordinates");
  if (m.cols != 3) throw Error("box_coordinates: x must have 3 columns, got " + s.str(), kExitInternal);
  const Shape want = s.rank() == 3 ? Shape{m.batch, 6} : Shape{6};
  if (!(box.shape() == want))
    throw Error("box_coordinates: box " + box.shape().str() + " must be " + want.str() + " for x " + s.str(),
                kExitInternal);
  Graph& g = *x.graph;
  Tensor y = g.activation(x.info().name + ".boxed", s);
  g.add(std::make_unique<BoxCoordinatesOp>(m.batch, m.rows), {x, box}, {y});
  return y;
}

}  // namespace nova

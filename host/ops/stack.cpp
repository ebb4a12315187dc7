// Stacking along the leading (NeRF) dimension: a static MLP's [M, C] output and a batched
// object MLP's [K, M, C] become one [1 + K, M, C] tensor for render_composite. The parts are
// contiguous blocks of the result, so both passes are flat block copies.
#include "nova/executor.hpp"
#include "nova/render.hpp"
#include "op_util.hpp"

namespace nova {
namespace {

class StackOp final : public Op {
 public:
  explicit StackOp(std::vector<size_t> sizes) : sizes_(std::move(sizes)) {
    for (size_t s : sizes_) total_ += s;
  }
  std::string type() const override { return "stack"; }

  // A flat block is copy_cols over one row (tensor.cl).
  void forward(ExecContext& ctx) override {
    size_t offset = 0;
    for (size_t i = 0; i < sizes_.size(); ++i) {
      ctx.launch("tensor", "copy_cols")
          .arg(ctx.in(i)).arg(ctx.out(0)).arg(1u).arg(detail::u32(sizes_[i], "part"))
          .arg(detail::u32(total_, "stack size")).arg(detail::u32(offset, "offset"))
          .run(sizes_[i]);
      offset += sizes_[i];
    }
  }

  void backward(ExecContext& ctx) override {
    cl_mem dy = ctx.grad_out(0);
    size_t offset = 0;
    for (size_t i = 0; i < sizes_.size(); ++i) {
      if (cl_mem dx = ctx.grad_in(i); dx && dy)
        ctx.launch("tensor", "copy_cols_back")
            .arg(dy).arg(dx).arg(1u).arg(detail::u32(sizes_[i], "part"))
            .arg(detail::u32(total_, "stack size")).arg(detail::u32(offset, "offset"))
            .arg(static_cast<int>(ctx.accumulate_in(i)))
            .run(sizes_[i]);
      offset += sizes_[i];
    }
  }

  std::vector<TensorId> saved_for_backward() const override { return {}; }

 private:
  std::vector<size_t> sizes_;
  size_t total_ = 0;
};

}  // namespace

Tensor stack(const std::vector<Tensor>& parts) {
  if (parts.empty()) throw Error("stack of nothing", kExitInternal);
  const auto inner = [](const Shape& s) {
    if (s.rank() == 2) return s;
    if (s.rank() == 3) return Shape{s[1], s[2]};
    throw Error("stack: parts must be [M, C] or [B, M, C], got " + s.str(), kExitInternal);
  };
  const Shape first = inner(parts[0].shape());
  size_t batch = 0;
  std::vector<size_t> sizes;
  for (const Tensor& t : parts) {
    if (!(inner(t.shape()) == first) || t.graph != parts[0].graph)
      throw Error("stack: " + t.shape().str() + " does not fit " + first.str(), kExitInternal);
    batch += t.shape().rank() == 3 ? t.shape()[0] : 1;
    sizes.push_back(t.shape().numel());
  }
  Graph& g = *parts[0].graph;
  Tensor y = g.activation(parts[0].info().name + ".stack", Shape{batch, first[0], first[1]});
  g.add(std::make_unique<StackOp>(sizes), parts, {y});
  return y;
}

}  // namespace nova

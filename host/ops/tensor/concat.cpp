// Concatenation along the last dimension (the skip connection that re-feeds the encoded
// input before layer 5); its backward splits the gradient into the parts.
#include "nova/graph/executor.hpp"
#include "nova/ops/tensor/tensor_ops.hpp"
#include "ops/tensor/concat_op.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

class ConcatOp final : public Op {
 public:
  ConcatOp(size_t rows, std::vector<size_t> widths, std::string type)
      : rows_(rows), widths_(std::move(widths)), type_(std::move(type)) {
    for (size_t w : widths_) total_ += w;
  }
  std::string type() const override { return type_; }

  // Parts two at a time (copy_cols2: half the launches, which a GPU pays for more than the
  // copy), a last odd one alone.
  void forward(ExecContext& ctx) override {
    const size_t rows = ctx.out_rows(0, rows_);
    if (rows == 0) return;
    size_t offset = 0;
    for (size_t i = 0; i < widths_.size(); i += 2) {
      if (i + 1 < widths_.size()) {
        ctx.launch("tensor", "copy_cols2")
            .arg(ctx.in(i)).arg(ctx.in(i + 1)).arg(ctx.out(0)).arg(detail::u32(rows, "rows"))
            .arg(detail::u32(widths_[i], "cols")).arg(detail::u32(widths_[i + 1], "cols"))
            .arg(detail::u32(total_, "cols")).arg(detail::u32(offset, "offset"))
            .run2(widths_[i] + widths_[i + 1], rows);
        offset += widths_[i] + widths_[i + 1];
        continue;
      }
      ctx.launch("tensor", "copy_cols")
          .arg(ctx.in(i)).arg(ctx.out(0)).arg(detail::u32(rows, "rows"))
          .arg(detail::u32(widths_[i], "cols")).arg(detail::u32(total_, "cols"))
          .arg(detail::u32(offset, "offset"))
          .run2(widths_[i], rows);
      offset += widths_[i];
    }
  }

  void backward(ExecContext& ctx) override {
    cl_mem dy = ctx.grad_out(0);
    const size_t rows = ctx.out_rows(0, rows_);
    if (!dy || rows == 0) return;
    size_t offset = 0;
    for (size_t i = 0; i < widths_.size(); i += 2) {
      // Two parts that are one tensor (concat(x, x)) share a gradient: one launch would write
      // and add the same elements from two work-items, a race a GPU loses (PoCL's CPU order
      // hides it); such a pair goes through two launches in order.
      if (i + 1 < widths_.size() && !(ctx.grad_in(i) && ctx.grad_in(i) == ctx.grad_in(i + 1))) {
        cl_mem d0 = ctx.grad_in(i), d1 = ctx.grad_in(i + 1);
        const unsigned wanted = (d0 ? 1u : 0u) | (d1 ? 2u : 0u) | (d0 && ctx.accumulate_in(i) ? 4u : 0u) |
                                (d1 && ctx.accumulate_in(i + 1) ? 8u : 0u);
        if (d0 || d1)
          ctx.launch("tensor", "copy_cols2_back")
              .arg(dy).arg(d0 ? d0 : d1).arg(d1 ? d1 : d0).arg(detail::u32(rows, "rows"))
              .arg(detail::u32(widths_[i], "cols")).arg(detail::u32(widths_[i + 1], "cols"))
              .arg(detail::u32(total_, "cols")).arg(detail::u32(offset, "offset")).arg(wanted)
              .run2(widths_[i] + widths_[i + 1], rows);
        offset += widths_[i] + widths_[i + 1];
        continue;
      }
      const size_t last = i + 1 < widths_.size() ? i + 1 : i;  // a shared pair, or a last odd part
      for (size_t j = i; j <= last; ++j) {
        if (cl_mem dx = ctx.grad_in(j))
          ctx.launch("tensor", "copy_cols_back")
              .arg(dy).arg(dx).arg(detail::u32(rows, "rows"))
              .arg(detail::u32(widths_[j], "cols")).arg(detail::u32(total_, "cols"))
              .arg(detail::u32(offset, "offset")).arg(static_cast<int>(ctx.accumulate_in(j)))
              .run2(widths_[j], rows);
        offset += widths_[j];
      }
    }
  }

  // The backward only moves gradients: no values are needed.
  std::vector<TensorId> saved_for_backward() const override { return {}; }

 private:
  size_t rows_;
  std::vector<size_t> widths_;
  std::string type_;
  size_t total_ = 0;
};

}  // namespace

std::unique_ptr<Op> make_column_concat(size_t rows, std::vector<size_t> widths, std::string type) {
  return std::make_unique<ConcatOp>(rows, std::move(widths), std::move(type));
}

Tensor concat(const std::vector<Tensor>& parts) {
  if (parts.empty()) throw Error("concat of nothing", kExitInternal);
  const Shape first = parts[0].shape();  // a copy: g.activation below may move the graph's tensors
  std::vector<size_t> widths;
  std::string name = parts[0].info().name;
  for (const Tensor& t : parts) {
    Shape a = t.shape(), b = first;
    a.dims.back() = b.dims.back() = 0;
    if (!(a == b) || t.graph != parts[0].graph)
      throw Error("concat: " + t.shape().str() + " does not fit " + first.str(), kExitInternal);
    widths.push_back(t.shape().cols());
  }
  Shape out = first;
  out.dims.back() = 0;
  for (size_t w : widths) out.dims.back() += w;
  Graph& g = *parts[0].graph;
  Tensor y = g.activation(name + ".cat", out);
  g.add(make_column_concat(first.rows(), widths, "concat"), parts, {y});
  return y;
}

}  // namespace nova

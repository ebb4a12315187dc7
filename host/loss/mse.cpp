// Mean squared error over all elements, as a deterministic two-stage sum.
#include <algorithm>

#include "nova/graph/executor.hpp"
#include "nova/loss/terms.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

class MseOp final : public Op {
 public:
  explicit MseOp(size_t n) : n_(n), parts_(detail::reduction_parts(n)) {}
  std::string type() const override { return "mse"; }

  void forward(ExecContext& ctx) override {
    const unsigned n = detail::u32(n_, "mse size"), parts = detail::u32(parts_, "parts");
    ctx.launch("loss", "sq_err_partial")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.workspace()).arg(n).arg(parts)
        .run(parts_);
    ctx.launch("loss", "sum_finish")
        .arg(ctx.workspace()).arg(ctx.out(0)).arg(parts).arg(1.0f / static_cast<float>(n_))
        .run(1);
  }

  void backward(ExecContext& ctx) override {
    cl_mem gl = ctx.grad_out(0);
    if (!gl) return;
    const float scale = 2.0f / static_cast<float>(n_);
    for (size_t i = 0; i < 2; ++i)
      if (cl_mem g = ctx.grad_in(i))
        ctx.launch("loss", "sq_err_backward")
            .arg(ctx.in(0)).arg(ctx.in(1)).arg(gl).arg(g).arg(detail::u32(n_, "mse size"))
            .arg(i == 0 ? scale : -scale).arg(static_cast<int>(ctx.accumulate_in(i)))
            .run(n_);
  }

  std::vector<TensorId> saved_for_backward() const override { return inputs(); }
  size_t workspace_bytes(Runtime&, Pass pass) const override {
    return pass == Pass::Forward ? parts_ * sizeof(float) : 0;
  }

 private:
  size_t n_, parts_;
};

class WeightedSumOp final : public Op {
 public:
  explicit WeightedSumOp(std::vector<float> w) : w_(std::move(w)) {}
  std::string type() const override { return "weighted_sum"; }

  // Eight terms a launch (kernels/loss.cl weighted_sum8): a step's loss sums a dozen terms,
  // and on a GPU each launch of a one-scalar kernel costs more than its arithmetic.
  void forward(ExecContext& ctx) override {
    for (size_t first = 0; first < w_.size(); first += kChunk) {
      const size_t n = std::min(kChunk, w_.size() - first);
      Launch l = ctx.launch("loss", "weighted_sum8");
      l.arg(ctx.out(0)).arg(static_cast<int>(first > 0)).arg(static_cast<unsigned>(n));
      for (size_t i = 0; i < kChunk; ++i) l.arg(ctx.in(first + std::min(i, n - 1)));
      for (size_t i = 0; i < kChunk; ++i) l.arg(i < n ? w_[first + i] : 0.0f);
      l.run(1);
    }
  }

  void backward(ExecContext& ctx) override {
    cl_mem gl = ctx.grad_out(0);
    if (!gl) return;
    for (size_t first = 0; first < w_.size(); first += kChunk) {
      const size_t n = std::min(kChunk, w_.size() - first);
      unsigned wanted = 0, accumulate = 0;
      cl_mem any = nullptr;
      for (size_t i = 0; i < n; ++i)
        if (cl_mem g = ctx.grad_in(first + i)) {
          wanted |= 1u << i;
          if (ctx.accumulate_in(first + i)) accumulate |= 1u << i;
          if (!any) any = g;
        }
      if (!wanted) continue;
      Launch l = ctx.launch("loss", "weighted_sum8_backward");
      l.arg(gl).arg(static_cast<unsigned>(n)).arg(wanted).arg(accumulate);
      for (size_t i = 0; i < kChunk; ++i) {
        cl_mem g = i < n ? ctx.grad_in(first + i) : nullptr;
        l.arg(g ? g : any);
      }
      for (size_t i = 0; i < kChunk; ++i) l.arg(i < n ? w_[first + i] : 0.0f);
      l.run(1);
    }
  }

  std::vector<TensorId> saved_for_backward() const override { return {}; }

 private:
  static constexpr size_t kChunk = 8;
  std::vector<float> w_;
};

}  // namespace

Tensor mse(Tensor pred, Tensor target) {
  if (!(pred.shape() == target.shape()))
    throw Error("mse: prediction " + pred.shape().str() + " and target " + target.shape().str() +
                    " differ",
                kExitInternal);
  Graph& g = *pred.graph;
  Tensor y = g.activation(pred.info().name + ".mse", Shape{1});
  g.add(std::make_unique<MseOp>(pred.shape().numel()), {pred, target}, {y});
  return y;
}

Tensor weighted_sum(const std::vector<Tensor>& terms, const std::vector<float>& weights) {
  if (terms.empty() || terms.size() != weights.size())
    throw Error("weighted_sum: " + std::to_string(terms.size()) + " terms and " +
                    std::to_string(weights.size()) + " weights",
                kExitInternal);
  for (const Tensor& t : terms)
    if (t.shape().numel() != 1)
      throw Error("weighted_sum: term '" + t.info().name + "' is not a scalar", kExitInternal);
  Graph& g = *terms[0].graph;
  Tensor y = g.activation("loss", Shape{1});
  g.add(std::make_unique<WeightedSumOp>(weights), terms, {y});
  return y;
}

}  // namespace nova

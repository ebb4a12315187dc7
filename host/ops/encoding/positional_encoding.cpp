// NeRF positional encoding: [p, sin(2^k p), cos(2^k p)] for k < L.
#include "nova/graph/executor.hpp"
#include "nova/ops/encoding/positional_encoding.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

class PositionalEncodingOp final : public Op {
 public:
  PositionalEncodingOp(size_t rows, size_t dims, int freqs) : rows_(rows), dims_(dims), freqs_(freqs) {}
  std::string type() const override { return "positional_encoding"; }

  void forward(ExecContext& ctx) override {
    const size_t rows = ctx.in_rows(0, rows_);
    if (rows == 0) return;
    ctx.launch("positional_encoding", "posenc_forward")
        .arg(ctx.in(0)).arg(ctx.out(0)).arg(detail::u32(rows, "rows"))
        .arg(detail::u32(dims_, "dims")).arg(static_cast<unsigned>(freqs_))
        .run(rows * dims_);
  }

  void backward(ExecContext& ctx) override {
    cl_mem dy = ctx.grad_out(0), dp = ctx.grad_in(0);
    const size_t rows = ctx.in_rows(0, rows_);
    if (!dy || !dp || rows == 0) return;
    ctx.launch("positional_encoding", "posenc_backward")
        .arg(ctx.in(0)).arg(dy).arg(dp).arg(detail::u32(rows, "rows"))
        .arg(detail::u32(dims_, "dims")).arg(static_cast<unsigned>(freqs_))
        .arg(static_cast<int>(ctx.accumulate_in(0)))
        .run(rows * dims_);
  }

  std::vector<TensorId> saved_for_backward() const override { return inputs(); }

 private:
  size_t rows_, dims_;
  int freqs_;
};

}  // namespace

Tensor positional_encoding(Tensor p, int frequencies) {
  if (frequencies < 0 || frequencies > 24)
    throw Error("positional_encoding: frequencies must be in [0, 24], got " +
                    std::to_string(frequencies),
                kExitUsage);
  Shape out = p.shape();
  out.dims.back() *= 1 + 2 * static_cast<size_t>(frequencies);
  Graph& g = *p.graph;
  Tensor y = g.activation(p.info().name + ".enc", out);
  g.add(std::make_unique<PositionalEncodingOp>(p.shape().rows(), p.shape().cols(), frequencies),
        {p}, {y});
  return y;
}

}  // namespace nova

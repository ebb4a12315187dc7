// y = act(h + b): bias and activation fused into one pass over the GEMM output.
#include "ops/linalg/layer_parts.hpp"
#include "nova/tuning/tuning.hpp"

namespace nova {
namespace {

std::string activation_options(Activation act) {
  return ActivationParams{static_cast<int>(act)}.to_defines();
}

}  // namespace

namespace detail {

void bias_act_backward(ExecContext& ctx, Matrix3 s, Activation act, size_t capacity, cl_mem y,
                       cl_mem dy, cl_mem dh, bool acc_dh, cl_mem db, bool acc_db,
                       cl_mem partials) {
  const std::string options = activation_options(act);
  const size_t n = s.batch * s.rows * s.cols, bc = s.batch * s.cols;
  // CPUs: one in-order pass writes the partial sums (bit for bit bias_grad_partial's) and dh.
  const BiasGradWalk walk = db ? bias_grad_walk(ctx.rt.info()) : BiasGradWalk::Strided;
  const bool row_walk = walk != BiasGradWalk::Strided;
  const size_t parts = bias_grad_parts(walk, capacity), folds = bias_grad_folds(parts);
  const bool write_dh = dh && n > 0;
  if (walk == BiasGradWalk::Host && (act == Activation::Identity || act == Activation::ReLU)) {
    bias_grad_rows_host(ctx.rt, s, act, parts, y, dy, partials, dh, acc_dh);
  } else if (row_walk) {
    const size_t chunks = (s.cols + kRowWalkColumns - 1) / kRowWalkColumns;
    ctx.launch("bias_act", "bias_grad_rows", options)
        .arg(y).arg(dy).arg(partials).arg(write_dh ? dh : partials).arg(u32(s.rows, "rows"))
        .arg(u32(s.cols, "cols")).arg(u32(s.batch, "batches")).arg(u32(parts, "parts"))
        .arg(static_cast<int>(write_dh)).arg(static_cast<int>(acc_dh))
        .run2(s.batch * chunks, 1, 1, 1);
  } else if (db) {  // dh in the same pass
    ctx.launch("bias_act", "bias_grad_partial", options)
        .arg(y).arg(dy).arg(partials).arg(write_dh ? dh : partials).arg(u32(s.rows, "rows"))
        .arg(u32(s.cols, "cols")).arg(u32(bc, "batch cols")).arg(u32(parts, "parts"))
        .arg(static_cast<int>(write_dh)).arg(static_cast<int>(acc_dh))
        .run2(bc, parts);
  }
  if (db) {
    size_t first = 0, last_parts = parts;
    if (folds > 0) {  // many parts (a GPU's strided walk): add them kFoldParts at a time first
      ctx.launch("reduce", "colsum_fold")
          .arg(partials).arg(u32(bc, "batch cols")).arg(u32(parts, "parts")).arg(u32(kFoldParts, "fold"))
          .run2(bc, folds);
      first = parts * bc;
      last_parts = folds;
    }
    ctx.launch("reduce", "colsum_finish")
        .arg(partials).arg(u32(first, "first partial")).arg(db).arg(u32(bc, "batch cols"))
        .arg(u32(last_parts, "parts")).arg(static_cast<int>(acc_db))
        .run(bc);
  }
  if (write_dh && !db)  // no bias gradient to take dh along with (and so no row walk)
    ctx.launch("bias_act", "bias_act_backward", options)
        .arg(y).arg(dy).arg(dh).arg(u32(n, "bias_act size")).arg(static_cast<int>(acc_dh))
        .run(n);
}

void bias_act_forward(Runtime& rt, Matrix3 s, Activation act, cl_mem h, cl_mem b, cl_mem y) {
  if (s.batch * s.rows * s.cols == 0) return;
  rt.launch("bias_act", "bias_act_forward", activation_options(act))
      .arg(h).arg(b).arg(y).arg(u32(s.cols, "cols")).arg(u32(s.rows, "rows"))
      .arg(u32(s.batch * s.rows, "bias_act rows"))
      .run2(s.cols, s.batch * s.rows);
}

}  // namespace detail

namespace {

class BiasActOp final : public Op {
 public:
  BiasActOp(detail::Matrix3 s, Activation act) : s_(s), act_(act) {}
  std::string type() const override { return std::string("bias_") + activation_name(act_); }

  void forward(ExecContext& ctx) override {
    detail::bias_act_forward(ctx.rt, {s_.batch, ctx.in_rows(0, s_.rows), s_.cols}, act_, ctx.in(0), ctx.in(1),
                             ctx.out(0));
  }

  void backward(ExecContext& ctx) override {
    cl_mem dy = ctx.grad_out(0);
    if (!dy) return;
    const detail::Matrix3 live{s_.batch, ctx.in_rows(0, s_.rows), s_.cols};
    detail::bias_act_backward(ctx, live, act_, s_.rows, ctx.out(0), dy, ctx.grad_in(0),
                              ctx.accumulate_in(0), ctx.grad_in(1), ctx.accumulate_in(1),
                              ctx.workspace());
  }

  // The derivative is computed from y; h is not needed.
  std::vector<TensorId> saved_for_backward() const override { return outputs(); }

  size_t workspace_bytes(Runtime&, Pass pass) const override {
    if (pass == Pass::Forward) return 0;
    return detail::bias_grad_workspace_floats(s_.rows, s_.batch * s_.cols) * sizeof(float);
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

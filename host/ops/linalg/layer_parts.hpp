#pragma once
// What a dense layer (dense.cpp) shares with linear and bias_act: the GEMMs of y = x w and of
// its gradients, and bias_act's backward.
#include <algorithm>

#include "nova/graph/executor.hpp"
#include "nova/ops/linalg/dense.hpp"
#include "nova/ops/linalg/gemm.hpp"
#include "nova/tuning/tuning.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova::detail {

// y = x w for `batch` networks: x [m, k], w [k, n], y [m, n] each, dense; m is the rows in use
// (packed samples run fewer than the capacity).
struct LinearShape {
  size_t batch, k, n;

  GemmArgs forward(cl_mem x, cl_mem w, cl_mem y, size_t m) const {
    return {false, false, m, n, k, 1.0f, x, k, m * k, w, n, k * n, 0.0f, y, n, m * n, batch};
  }
  // dx (+)= dy w^T: [m, n] x [n, k].
  GemmArgs dx(cl_mem dy, cl_mem w, cl_mem dx, bool acc, size_t m) const {
    return {false, true, m, k, n, 1.0f, dy, n, m * n, w, n, k * n, acc ? 1.0f : 0.0f,
            dx, k, m * k, batch};
  }
  // dw (+)= x^T dy: [k, m] x [m, n].
  GemmArgs dw(cl_mem x, cl_mem dy, cl_mem dw, bool acc, size_t m) const {
    return {true, false, k, n, m, 1.0f, x, k, m * k, dy, n, m * n, acc ? 1.0f : 0.0f,
            dw, n, k * n, batch};
  }
  // The input and weight gradients from dy (dx or dw null: not wanted). No rows: dw = 0.
  void backward(Runtime& rt, cl_mem x, cl_mem w, cl_mem dy, cl_mem dx_out, bool acc_dx,
                cl_mem dw_out, bool acc_dw, size_t m, cl_mem temp) const;
  // Scratch of backward at m rows.
  size_t backward_bytes(Runtime& rt, size_t m) const;
};

// The bias gradient's first stage sums each column's rows in `parts` interleaved parts (row r
// into part r % parts), about 64 rows a part. A walk in row order (CPUs: bias_grad_rows keeps
// the parts in registers) takes at most 64; the strided kernel (GPUs: one work-item per
// column and part) up to 1024, so that a few columns still give the GPU work-items enough to
// fill it. Up to 4159 rows both take the same parts, and the same sums bit for bit.
constexpr size_t kRowWalkMaxParts = 64;
constexpr size_t kStridedMaxParts = 1024;
inline size_t bias_grad_parts(BiasGradWalk walk, size_t rows) {
  const size_t cap = walk == BiasGradWalk::Strided ? kStridedMaxParts : kRowWalkMaxParts;
  return std::min<size_t>(cap, std::max<size_t>(1, rows / 64));
}
// Over kRowWalkMaxParts parts, a middle stage adds them kFoldParts at a time (colsum_fold), so
// that the last stage's work-items, one per column, add at most 32 values each.
constexpr size_t kFoldParts = 32;
inline size_t bias_grad_folds(size_t parts) {
  return parts > kRowWalkMaxParts ? (parts + kFoldParts - 1) / kFoldParts : 0;
}
// Scratch floats of bias_act's backward at `rows` rows (at capacity) of `batch_cols` columns,
// whichever walk runs (NOVA_BIAS_GRAD is read when the op runs).
inline size_t bias_grad_workspace_floats(size_t rows, size_t batch_cols) {
  const size_t parts = bias_grad_parts(BiasGradWalk::Strided, rows);
  return (parts + bias_grad_folds(parts)) * batch_cols;
}

// Columns per work-item of bias_grad_rows (one float8): a 256-wide layer gives 32 work-items,
// a 64-wide one 8, each its own work-group, so a CPU device's threads share them.
constexpr size_t kRowWalkColumns = 8;

// y = act(h + b) over s (s.rows: the rows in use), b one row per batch; y may be h itself.
void bias_act_forward(Runtime& rt, Matrix3 s, Activation act, cl_mem h, cl_mem b, cl_mem y);

// bias_act's backward over s (s.rows: the rows in use; capacity: the rows the op was built
// for, which fix the parts) from y = act(h + b) and dy: first db (+)= column sums of
// dy act'(y) (in stages through `partials`, bias_grad_workspace_floats(capacity, batch x cols)
// floats), then dh (+)= dy act'(y). Either output may be null. dh may be dy itself
// (overwritten in place): db reads dy before. Where bias_grad_walk says Rows or Host both are
// done in one pass in row order (bias_grad_rows, or bias_grad_rows_host), with the values of
// the strided kernel at the same parts bit for bit.
void bias_act_backward(ExecContext& ctx, Matrix3 s, Activation act, size_t capacity, cl_mem y,
                       cl_mem dy, cl_mem dh, bool acc_dh, cl_mem db, bool acc_db,
                       cl_mem partials);

// bias_grad_rows as a host function on rt's queue (bias_grad_host.cpp): the partial sums and
// dh (+)= dy act'(y) (dh null: not written) of the kernel, bit for bit; the identity and ReLU
// only; rt's device must run native kernels (native_call.hpp).
void bias_grad_rows_host(Runtime& rt, Matrix3 s, Activation act, size_t parts, cl_mem y,
                         cl_mem dy, cl_mem partials, cl_mem dh, bool acc_dh);

}  // namespace nova::detail

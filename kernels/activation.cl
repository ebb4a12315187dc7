// Fused bias + activation, y = act(h + b), and its backward from the output alone.
// ACT (a build option) selects the activation: 0 identity, 1 ReLU, 2 sigmoid, 3 softplus.
// Layout: h, y [B, rows, cols] flat; b [B, cols]; per_batch = rows * cols.

#ifndef ACT
#define ACT 0
#endif

inline float act_forward(float x) {
#if ACT == 1
  return fmax(x, 0.0f);
#elif ACT == 2
  return NOVA_SIGMOID(x);
#elif ACT == 3
  return NOVA_SOFTPLUS(x);
#else
  return x;
#endif
}

// d act / dx written in terms of y = act(x), so the backward needs only the output.
inline float act_derivative(float y) {
#if ACT == 1
  return y > 0.0f ? 1.0f : 0.0f;
#elif ACT == 2
  return y * (1.0f - y);
#elif ACT == 3
  // softplus' = sigmoid(x) = 1 - e^-y; expm1 keeps precision where y is tiny.
  return -expm1(-y);
#else
  return 1.0f;
#endif
}

// 2D over (cols, all rows of all batches): the bias column is the work-item's first index and
// its batch a division per row, so no element pays an integer division (a CPU device runs
// dimension 0 as vector lanes; per-element i / per_batch and i % cols cost more than the add).
__kernel void bias_act_forward(__global const float* h, __global const float* b,
                               __global float* y, uint cols, uint rows, uint total_rows) {
  const uint j = get_global_id(0), r = get_global_id(1);
  if (j >= cols || r >= total_rows) return;
  const size_t i = (size_t)r * cols + j;
  y[i] = act_forward(h[i] + b[(r / rows) * cols + j]);
}

__kernel void bias_act_backward(__global const float* y, __global const float* dy,
                                __global float* dh, uint n, int accumulate) {
  // No multiply-add contraction: the three backward kernels round dy act'(y) alike, so the
  // two bias-gradient summations agree bit for bit whatever a compiler would fuse.
#pragma OPENCL FP_CONTRACT OFF
  const uint i = get_global_id(0);
  if (i >= n) return;
  const float g = dy[i] * act_derivative(y[i]);
  dh[i] = accumulate ? dh[i] + g : g;
}

// Bias gradient, stage 1: partial[p, j] = sum over rows p, p + parts, ... of dy * act'(y) in
// column j % cols of batch j / cols. Stage 2 is colsum_finish (reduce.cl). Reading y and dy
// directly keeps db independent of whatever else accumulates into dh.
__kernel void bias_grad_partial(__global const float* y, __global const float* dy,
                                __global float* partial, uint rows, uint cols, uint batch_cols,
                                uint parts) {
#pragma OPENCL FP_CONTRACT OFF  // as in bias_act_backward
  const uint j = get_global_id(0);
  const uint p = get_global_id(1);
  if (j >= batch_cols || p >= parts) return;
  const size_t base = (size_t)(j / cols) * rows * cols + j % cols;
  float s = 0.0f;
  for (uint r = p; r < rows; r += parts) {
    const size_t i = base + (size_t)r * cols;
    s += dy[i] * act_derivative(y[i]);
  }
  partial[(size_t)p * batch_cols + j] = s;
}

// The bias gradient for devices that read memory best in order (CPUs): one work-item per
// column j walks its rows in order and keeps the `parts` partial sums of bias_grad_partial in
// private memory (row r adds to sum r % parts), so the partials, and db after colsum_finish,
// are those of bias_grad_partial bit for bit, while memory is read row after row instead of
// `parts` rows apart. It also writes dh (+)= dy act'(y) on the way (bias_act_backward's
// values; dh may be dy itself: each element is read before it is written). BIAS_GRAD_PARTS
// bounds `parts` (bias_grad_parts: at most 64).
#ifndef BIAS_GRAD_PARTS
#define BIAS_GRAD_PARTS 64
#endif
__kernel void bias_grad_rows(__global const float* y, __global const float* dy,
                             __global float* partial, __global float* dh, uint rows, uint cols,
                             uint batch_cols, uint parts, int write_dh, int accumulate_dh) {
#pragma OPENCL FP_CONTRACT OFF  // as in bias_act_backward
  const uint j = get_global_id(0);
  if (j >= batch_cols) return;
  const size_t base = (size_t)(j / cols) * rows * cols + j % cols;
  float s[BIAS_GRAD_PARTS];
  for (uint p = 0; p < parts; ++p) s[p] = 0.0f;
  for (uint r0 = 0; r0 < rows; r0 += parts) {
    const uint n = min(parts, rows - r0);
    for (uint p = 0; p < n; ++p) {
      const size_t i = base + (size_t)(r0 + p) * cols;
      const float g = dy[i] * act_derivative(y[i]);
      s[p] += g;
      if (write_dh) dh[i] = accumulate_dh ? dh[i] + g : g;
    }
  }
  for (uint p = 0; p < parts; ++p) partial[(size_t)p * batch_cols + j] = s[p];
}

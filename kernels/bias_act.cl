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
// directly keeps db independent of whatever else accumulates into dh. With write_dh it also
// writes dh (+)= dy act'(y) for the elements it reads, bias_act_backward's values, in the same
// pass (one launch and one read of y and dy fewer); dh may be dy itself, each element being
// read before it is written by the one work-item that owns it.
__kernel void bias_grad_partial(__global const float* y, __global const float* dy,
                                __global float* partial, __global float* dh, uint rows, uint cols,
                                uint batch_cols, uint parts, int write_dh, int accumulate_dh) {
#pragma OPENCL FP_CONTRACT OFF  // as in bias_act_backward
  const uint j = get_global_id(0);
  const uint p = get_global_id(1);
  if (j >= batch_cols || p >= parts) return;
  const size_t base = (size_t)(j / cols) * rows * cols + j % cols;
  float s = 0.0f;
  for (uint r = p; r < rows; r += parts) {
    const size_t i = base + (size_t)r * cols;
    const float g = dy[i] * act_derivative(y[i]);
    s += g;
    if (write_dh) dh[i] = accumulate_dh ? dh[i] + g : g;
  }
  partial[(size_t)p * batch_cols + j] = s;
}

// act_derivative of eight values at once.
inline float8 act_derivative8(float8 y) {
#if ACT == 1
  return select((float8)(0.0f), (float8)(1.0f), y > (float8)(0.0f));
#elif ACT == 0
  return (float8)(1.0f);
#else  // lane by lane: the scalar function's exact values
  return (float8)(act_derivative(y.s0), act_derivative(y.s1), act_derivative(y.s2), act_derivative(y.s3),
                  act_derivative(y.s4), act_derivative(y.s5), act_derivative(y.s6), act_derivative(y.s7));
#endif
}

// The bias gradient for devices that read memory best in order (CPUs): one work-item per
// eight adjacent columns of one batch walks their rows in order and keeps the `parts`
// partial sums of bias_grad_partial for each in private memory (row r adds to sum r % parts),
// so the partials, and db after colsum_finish, are those of bias_grad_partial bit for bit,
// while memory is read row after row instead of `parts` rows apart by one work-item per
// column. A full chunk of eight columns is read, summed and written as one float8; a ragged
// last chunk of a batch element by element, with the same arithmetic. It also writes
// dh (+)= dy act'(y) on the way (bias_act_backward's values; dh may be dy itself: each element
// is read before it is written). `parts` is at most 64 (bias_grad_parts).
__kernel void bias_grad_rows(__global const float* y, __global const float* dy,
                             __global float* partial, __global float* dh, uint rows, uint cols,
                             uint batches, uint parts, int write_dh, int accumulate_dh) {
#pragma OPENCL FP_CONTRACT OFF  // as in bias_act_backward
  const uint chunks = (cols + 7) / 8;
  const uint w = get_global_id(0);
  if (w >= batches * chunks) return;
  const uint batch = w / chunks, c0 = (w % chunks) * 8;
  const uint width = min(8u, cols - c0);
  const size_t base = (size_t)batch * rows * cols + c0;
  float8 s[64];
  for (uint p = 0; p < parts; ++p) s[p] = (float8)(0.0f);
  for (uint r0 = 0; r0 < rows; r0 += parts) {
    const uint n = min(parts, rows - r0);
    for (uint p = 0; p < n; ++p) {
      const size_t row = base + (size_t)(r0 + p) * cols;
      if (width == 8) {
        const float8 g = vload8(0, dy + row) * act_derivative8(vload8(0, y + row));
        s[p] += g;
        if (write_dh) vstore8(accumulate_dh ? vload8(0, dh + row) + g : g, 0, dh + row);
      } else {
        float part[8];
        vstore8(s[p], 0, part);
        for (uint c = 0; c < width; ++c) {
          const float g = dy[row + c] * act_derivative(y[row + c]);
          part[c] += g;
          if (write_dh) dh[row + c] = accumulate_dh ? dh[row + c] + g : g;
        }
        s[p] = vload8(0, part);
      }
    }
  }
  const uint batch_cols = batches * cols;
  for (uint p = 0; p < parts; ++p) {
    float part[8];
    vstore8(s[p], 0, part);
    for (uint c = 0; c < width; ++c) partial[(size_t)p * batch_cols + batch * cols + c0 + c] = part[c];
  }
}

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

__kernel void bias_act_forward(__global const float* h, __global const float* b,
                               __global float* y, uint n, uint cols, uint per_batch) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  const uint bias = (i / per_batch) * cols + i % cols;
  y[i] = act_forward(h[i] + b[bias]);
}

__kernel void bias_act_backward(__global const float* y, __global const float* dy,
                                __global float* dh, uint n, int accumulate) {
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

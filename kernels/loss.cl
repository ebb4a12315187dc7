// Losses: forward as deterministic two-stage sums, gradients elementwise.

// partial[i] = sum of (pred - target)^2 over elements i, i + parts, ...
__kernel void sq_err_partial(__global const float* pred, __global const float* target,
                             __global float* partial, uint n, uint parts) {
  const uint i = get_global_id(0);
  if (i >= parts) return;
  float s = 0.0f;
  for (uint e = i; e < n; e += parts) {
    const float d = pred[e] - target[e];
    s += d * d;
  }
  partial[i] = s;
}

// out[0] = scale * sum(partial): a single work-item.
__kernel void sum_finish(__global const float* partial, __global float* out, uint parts,
                         float scale) {
  if (get_global_id(0) != 0) return;
  float s = 0.0f;
  for (uint i = 0; i < parts; ++i) s += partial[i];
  out[0] = scale * s;
}

// grad (+)= gloss[0] * scale * (pred - target); scale = +-2/n for d/dpred and d/dtarget.
__kernel void sq_err_backward(__global const float* pred, __global const float* target,
                              __global const float* gloss, __global float* grad, uint n,
                              float scale, int accumulate) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  const float g = gloss[0] * scale * (pred[i] - target[i]);
  grad[i] = accumulate ? grad[i] + g : g;
}

// out[0] (+)= w * x[0]: one term of a weighted sum of scalars.
__kernel void scalar_axpy(__global const float* x, __global float* out, float w, int accumulate) {
  if (get_global_id(0) != 0) return;
  out[0] = accumulate ? out[0] + w * x[0] : w * x[0];
}

// Deterministic two-stage sums (no atomics, no local memory: the same bits on every run,
// which exact resume needs, and no PoCL barrier pitfalls).

// Stage 2 of a column sum whose stage 1 wrote partial[parts, batch_cols] (for example
// bias_grad_partial in bias_act.cl):
// out[j] (+)= sum_p partial[p, j].
__kernel void colsum_finish(__global const float* partial, __global float* out, uint batch_cols,
                            uint parts, int accumulate) {
  const uint j = get_global_id(0);
  if (j >= batch_cols) return;
  float s = 0.0f;
  for (uint p = 0; p < parts; ++p) s += partial[(size_t)p * batch_cols + j];
  out[j] = accumulate ? out[j] + s : s;
}

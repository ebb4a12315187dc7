// Deterministic two-stage sums (no atomics, no local memory: the same bits on every run,
// which exact resume needs, and no PoCL barrier pitfalls).

// Stage 2 of a column sum whose stage 1 wrote partial[parts, batch_cols] from float `first` of
// the buffer on (for example bias_grad_partial in bias_act.cl):
// out[j] (+)= sum_p partial[first + p * batch_cols + j].
__kernel void colsum_finish(__global const float* partial, uint first, __global float* out,
                            uint batch_cols, uint parts, int accumulate) {
  const uint j = get_global_id(0);
  if (j >= batch_cols) return;
  partial += first;
  float s = 0.0f;
  for (uint p = 0; p < parts; ++p) s += partial[(size_t)p * batch_cols + j];
  out[j] = accumulate ? out[j] + s : s;
}

// A middle stage for many parts (a GPU's strided bias gradient): work-item (j, g) adds parts
// g * fold ... g * fold + fold - 1 of column j, in order, into row g of the folded sums, which
// lie in the same buffer after the parts (from float parts * batch_cols on); colsum_finish
// then adds the ceil(parts / fold) rows.
__kernel void colsum_fold(__global float* partial, uint batch_cols, uint parts, uint fold) {
  const uint j = get_global_id(0), g = get_global_id(1);
  if (j >= batch_cols || g * fold >= parts) return;
  const uint end = min(parts, g * fold + fold);
  float s = 0.0f;
  for (uint p = g * fold; p < end; ++p) s += partial[(size_t)p * batch_cols + j];
  partial[((size_t)parts + g) * batch_cols + j] = s;
}

// Adam with bias correction, over a whole parameter arena at once (PyTorch's formulation):
// m = b1 m + (1 - b1) g; v = b2 v + (1 - b2) g^2;
// p -= step_size * m / (sqrt(v) / bc2_sqrt + eps), step_size = lr / (1 - b1^t),
// bc2_sqrt = sqrt(1 - b2^t). Parameters [scaled_first, scaled_end) step at `scale` times the
// rate (Adam::scale_range).
__kernel void adam_step(__global float* p, __global const float* g, __global float* m,
                        __global float* v, uint n, float step_size, float beta1, float beta2,
                        float bc2_sqrt, float eps, uint scaled_first,
                        uint scaled_end, float scale) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  const float gi = g[i];
  const float mi = beta1 * m[i] + (1.0f - beta1) * gi;
  const float vi = beta2 * v[i] + (1.0f - beta2) * gi * gi;
  m[i] = mi;
  v[i] = vi;
  const float rate = i >= scaled_first && i < scaled_end ? scale * step_size : step_size;
  p[i] -= rate * mi / (sqrt(vi) / bc2_sqrt + eps);
}

// The novel-view losses as the public reference code normalises them (losses.hpp,
// LossConventions): per-NeRF ratios of two sums, forward as deterministic two-stage sums,
// gradients elementwise.
//
// A "group ratio" loss is sum over groups g of num_g / (den_g + eps) / c. The partial
// kernels write, for group g and part p, num into partial[(2 g) parts + p] and den into
// partial[(2 g + 1) parts + p]; group_ratio_finish sums them in a fixed order, and
// group_ratio_factor gives each group's d loss / d num_g = 1 / ((den_g + eps) c) (0 when
// den_g + eps is 0: an empty group adds nothing) for the backward kernels.


inline float group_sum(__global const float* partial, uint at, uint parts) {
  float s = 0.0f;
  for (uint i = 0; i < parts; ++i) s += partial[at + i];
  return s;
}

// out[0] = sum_g num_g / (den_g + eps) / c: a single work-item.
__kernel void group_ratio_finish(__global const float* partial, __global float* out, uint groups,
                                 uint parts, float c, float eps) {
  if (get_global_id(0) != 0) return;
  float s = 0.0f;
  for (uint g = 0; g < groups; ++g) {
    const float num = group_sum(partial, 2 * g * parts, parts);
    const float den = group_sum(partial, (2 * g + 1) * parts, parts) + eps;
    if (den > 0.0f) s += num / den / c;
  }
  out[0] = s;
}

// partial[2 groups parts + g] = 1 / ((den_g + eps) c), 0 for an empty group: the factors
// follow the partial sums in the same buffer (the backward kernels read them at factor_at).
__kernel void group_ratio_factor(__global float* partial, uint groups, uint parts, float c,
                                 float eps) {
  const uint g = get_global_id(0);
  if (g >= groups) return;
  const float den = group_sum(partial, (2 * g + 1) * parts, parts) + eps;
  partial[2 * groups * parts + g] = den > 0.0f ? 1.0f / (den * c) : 0.0f;
}

// Split over ranks (data-parallel training): a rank's sums, out[2 g] = num_g and out[2 g + 1]
// = den_g (the partial layout with one part), which the sum over ranks makes the whole batch's;
// group_ratio_finish with parts = 1 then finishes the loss from them.
__kernel void group_sums_finish(__global const float* partial, __global float* out, uint groups,
                                uint parts) {
  const uint i = get_global_id(0);
  if (i >= 2 * groups) return;
  out[i] = group_sum(partial, i * parts, parts);
}

// The backward of the sums: d loss / d num_g = gsums[2 g] becomes the factor of group g at
// partial[1 + g], and partial[0] = 1 stands for the upstream gradient (the backward kernels
// read gloss[0] factor[factor_at + g] with gloss = partial and factor_at = 1).
__kernel void group_sums_factor(__global const float* gsums, __global float* partial, uint groups) {
  const uint g = get_global_id(0);
  if (g >= groups) return;
  if (g == 0) partial[0] = 1.0f;
  partial[1 + g] = gsums[2 * g];
}

// The gradient of group_ratio_finish(sums, parts = 1) by its sums [2 groups]: for a group with
// den_g + eps > 0, d / d num_g = gloss / ((den_g + eps) c) and d / d den_g = -gloss num_g /
// ((den_g + eps)^2 c); 0 for an empty group.
__kernel void group_ratio_backward(__global const float* sums, __global const float* gloss,
                                   __global float* grad, uint groups, float c, float eps,
                                   int accumulate) {
  const uint i = get_global_id(0);
  if (i >= 2 * groups) return;
  const uint g = i / 2;
  const float num = sums[2 * g], den = sums[2 * g + 1] + eps;
  float v = 0.0f;
  if (den > 0.0f) v = i % 2 == 0 ? gloss[0] / (den * c) : -gloss[0] * num / (den * den * c);
  grad[i] = accumulate ? grad[i] + v : v;
}

// Per-NeRF masked squared error, pred [G, R, K], target [G, R, K] (target_stride R K) or
// [R, K] (0), mask [G, R]; one work-item per (group g, part p):
// num = sum over rays r = p, p + parts, ... of mask_g(r) sum_k (pred - target)^2, den = sum mask.
__kernel void masked_sq_err_group_partial(__global const float* pred, __global const float* target,
                                          __global const float* mask, __global float* partial,
                                          uint G, uint R, uint K, uint target_stride, uint parts) {
  const uint q = get_global_id(0);
  if (q >= G * parts) return;
  const uint g = q / parts, p = q % parts;
  float num = 0.0f, den = 0.0f;
  for (uint r = p; r < R; r += parts) {
    const float m = mask[(size_t)g * R + r];
    float s = 0.0f;
    for (uint k = 0; k < K; ++k) {
      const float d = pred[((size_t)g * R + r) * K + k] - target[(size_t)g * target_stride + r * K + k];
      s += d * d;
    }
    num += m * s;
    den += m;
  }
  partial[2 * g * parts + p] = num;
  partial[(2 * g + 1) * parts + p] = den;
}

// grad_pred (+)= gloss factor_g 2 mask (pred - target).
__kernel void masked_sq_err_group_backward(__global const float* pred, __global const float* target,
                                           __global const float* mask, __global const float* factor, uint factor_at,
                                           __global const float* gloss, __global float* grad, uint G,
                                           uint R, uint K, uint target_stride, int accumulate) {
  const uint e = get_global_id(0);
  if (e >= G * R * K) return;
  const uint g = e / (R * K), rk = e % (R * K);
  const float d = pred[e] - target[(size_t)g * target_stride + rk];
  const float v = gloss[0] * factor[factor_at + g] * 2.0f * mask[(size_t)g * R + rk / K] * d;
  grad[e] = accumulate ? grad[e] + v : v;
}

// Alpha loss of the reference code, raw [N, R*S, C], delta [R, S] or [N, R, S] (delta_stride
// 0 or R*S), noise [N, R, S] (use_noise), mask [N, R]. Group g is object NeRF n = g + 1; its
// rays are those with mask_n(r) != 1: num = sum over their samples of alpha + blend, den =
// their count (finished with c = S: the mean of |blend| plus the mean of |alpha| over them).
__kernel void alpha_outside_group_partial(__global const float* raw, __global const float* delta,
                                          __global const float* noise, __global const float* mask,
                                          __global float* partial, uint N, uint R, uint S, uint C,
                                          uint delta_stride, int use_noise, int act, uint parts) {
  const uint q = get_global_id(0);
  if (q >= (N - 1) * parts) return;
  const uint g = q / parts, p = q % parts, n = g + 1;
  const size_t rs = (size_t)R * S;
  float num = 0.0f, den = 0.0f;
  for (uint r = p; r < R; r += parts) {
    if (mask[(size_t)n * R + r] == 1.0f) continue;
    den += 1.0f;
    for (uint i = 0; i < S; ++i) {
      const size_t at = (size_t)r * S + i, e = n * rs + at;
      const float alpha = nova_alpha(raw[e * C + 3] + (use_noise ? noise[e] : 0.0f), delta[n * (size_t)delta_stride + at]);
      num += alpha + nova_blend(raw[e * C + 4], act);
    }
  }
  partial[2 * g * parts + p] = num;
  partial[(2 * g + 1) * parts + p] = den;
}

// One work-item per raw element: sigma and blend of object samples on rays with mask != 1
// get gloss factor_{n-1} d(alpha + blend); everything else 0.
__kernel void alpha_outside_group_backward(__global const float* raw, __global const float* delta,
                                           __global const float* noise, __global const float* mask,
                                           __global const float* factor, uint factor_at, __global const float* gloss,
                                           __global float* grad, uint N, uint R, uint S, uint C,
                                           uint delta_stride, int use_noise, int act, int accumulate) {
  const uint e = get_global_id(0);
  if (e >= N * R * S * C) return;
  const uint sample = e / C, ch = e % C, rs = R * S;
  const uint n = sample / rs, at = sample % rs;
  float g = 0.0f;
  if (n >= 1 && (ch == 3 || ch == 4) && mask[n * R + at / S] != 1.0f) {
    const float w = gloss[0] * factor[factor_at + n - 1];
    if (ch == 3) {
      const float s = raw[e] + (use_noise ? noise[sample] : 0.0f);
      const float d = delta[n * delta_stride + at];
      const float t = nova_transmittance(s, d);
      // d alpha / d sigma = delta exp(-sigma delta), 0 once exp underflows, 0 below the ReLU.
      g = s > 0.0f && t > 0.0f ? w * t * d : 0.0f;
    } else {
      g = w * nova_blend_slope(nova_blend(raw[e], act), act);
    }
  }
  grad[e] = accumulate ? grad[e] + g : g;
}

// Order loss, depth [N, R] (each NeRF with its own transmittance), mask [N, R] (row 0: the
// background): one group, num = sum over rays r = p, p + parts, ... of
// mask_0(r) sum_{n >= 1} |depth_n(r) - depth_0(r)|, den = sum mask_0.
__kernel void order_partial(__global const float* depth, __global const float* mask,
                            __global float* partial, uint N, uint R, uint parts) {
  const uint p = get_global_id(0);
  if (p >= parts) return;
  float num = 0.0f, den = 0.0f;
  for (uint r = p; r < R; r += parts) {
    const float m = mask[r];
    float s = 0.0f;
    for (uint n = 1; n < N; ++n) s += fabs(depth[(size_t)n * R + r] - depth[r]);
    num += m * s;
    den += m;
  }
  partial[p] = num;
  partial[parts + p] = den;
}

// grad_depth (+)= gloss factor_0 mask_0 d|depth_n - depth_0|: sign(d_n - d_0) for n >= 1,
// minus their sum for the static NeRF (sign(0) = 0).
__kernel void order_backward(__global const float* depth, __global const float* mask,
                             __global const float* factor, uint factor_at, __global const float* gloss,
                             __global float* grad, uint N, uint R, int accumulate) {
  const uint e = get_global_id(0);
  if (e >= N * R) return;
  const uint n = e / R, r = e % R;
  float s = 0.0f;
  if (n >= 1) {
    s = sign(depth[e] - depth[r]);
  } else {
    for (uint k = 1; k < N; ++k) s -= sign(depth[(size_t)k * R + r] - depth[r]);
  }
  const float v = gloss[0] * factor[factor_at] * mask[r] * s;
  grad[e] = accumulate ? grad[e] + v : v;
}

// Mean absolute error scaled: partial[p] = sum over e = p, p + parts, ... of |pred - target|
// (finished by loss.cl's sum_finish pattern here: abs_err_finish).
__kernel void abs_err_partial(__global const float* pred, __global const float* target,
                              __global float* partial, uint n, uint parts) {
  const uint p = get_global_id(0);
  if (p >= parts) return;
  float s = 0.0f;
  for (uint e = p; e < n; e += parts) s += fabs(pred[e] - target[e]);
  partial[p] = s;
}

// Stage 2 is loss.cl's sum_finish.

// grad (+)= gloss scale sign(pred - target).
__kernel void abs_err_backward(__global const float* pred, __global const float* target,
                               __global const float* gloss, __global float* grad, uint n,
                               float scale, int accumulate) {
  const uint e = get_global_id(0);
  if (e >= n) return;
  const float v = gloss[0] * scale * sign(pred[e] - target[e]);
  grad[e] = accumulate ? grad[e] + v : v;
}

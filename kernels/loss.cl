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

// A weighted sum of scalars, eight terms a launch (a step's loss has a dozen): out[0] (+)=
// w0 x0[0] + w1 x1[0] + ... over the first n terms, added in order. Unused term arguments may
// repeat a used buffer.
__kernel void weighted_sum8(__global float* out, int accumulate, uint n,
                            __global const float* x0, __global const float* x1, __global const float* x2,
                            __global const float* x3, __global const float* x4, __global const float* x5,
                            __global const float* x6, __global const float* x7, float w0, float w1,
                            float w2, float w3, float w4, float w5, float w6, float w7) {
  if (get_global_id(0) != 0) return;
  float s = accumulate ? out[0] + w0 * x0[0] : w0 * x0[0];
  if (n > 1) s = s + w1 * x1[0];
  if (n > 2) s = s + w2 * x2[0];
  if (n > 3) s = s + w3 * x3[0];
  if (n > 4) s = s + w4 * x4[0];
  if (n > 5) s = s + w5 * x5[0];
  if (n > 6) s = s + w6 * x6[0];
  if (n > 7) s = s + w7 * x7[0];
  out[0] = s;
}

// Its backward for eight terms: g_i[0] (+)= w_i gl[0] for the first n terms whose bit i of
// `wanted` is set, added to where bit i of `accumulate` is.
#define WEIGHTED_SUM_GRAD(i, g, w) \
  if (n > i && ((wanted >> i) & 1u)) g[0] = ((accumulate >> i) & 1u) ? g[0] + w * v : w * v;
__kernel void weighted_sum8_backward(__global const float* gl, uint n, uint wanted, uint accumulate,
                                     __global float* g0, __global float* g1, __global float* g2,
                                     __global float* g3, __global float* g4, __global float* g5,
                                     __global float* g6, __global float* g7, float w0, float w1,
                                     float w2, float w3, float w4, float w5, float w6, float w7) {
  if (get_global_id(0) != 0) return;
  const float v = gl[0];
  WEIGHTED_SUM_GRAD(0, g0, w0)
  WEIGHTED_SUM_GRAD(1, g1, w1)
  WEIGHTED_SUM_GRAD(2, g2, w2)
  WEIGHTED_SUM_GRAD(3, g3, w3)
  WEIGHTED_SUM_GRAD(4, g4, w4)
  WEIGHTED_SUM_GRAD(5, g5, w5)
  WEIGHTED_SUM_GRAD(6, g6, w6)
  WEIGHTED_SUM_GRAD(7, g7, w7)
}
#undef WEIGHTED_SUM_GRAD

// ---- novel-view losses (render.hpp / losses.hpp) ---------------------------------------------
// Raw field rows are [rgb(3), sigma, blend, ...] of C channels (kRaw* in render.hpp); `act`
// says whether the blend channel still needs its sigmoid.


// Masked squared error, pred [G, R, K], target [R, K], mask [G, R]:
// partial[p] = sum over elements e = p, p + parts, ... of mask (pred - target)^2.
__kernel void masked_sq_err_partial(__global const float* pred, __global const float* target,
                                    __global const float* mask, __global float* partial, uint n,
                                    uint R, uint K, uint parts) {
  const uint p = get_global_id(0);
  if (p >= parts) return;
  const uint rk = R * K;
  float s = 0.0f;
  for (uint e = p; e < n; e += parts) {
    const float d = pred[e] - target[e % rk];
    s += mask[e / K] * d * d;
  }
  partial[p] = s;
}

// grad_pred (+)= gloss * scale * mask (pred - target), scale = 2 / n.
__kernel void masked_sq_err_backward(__global const float* pred, __global const float* target,
                                     __global const float* mask, __global const float* gloss,
                                     __global float* grad, uint n, uint R, uint K, float scale,
                                     int accumulate) {
  const uint e = get_global_id(0);
  if (e >= n) return;
  const float g = gloss[0] * scale * mask[e / K] * (pred[e] - target[e % (R * K)]);
  grad[e] = accumulate ? grad[e] + g : g;
}

// Blending loss, raw [N, M, C]: partial[p] = sum over samples m = p, p + parts, ... of
// |sum_n blend_n(m) - 1|.
__kernel void blend_sum_partial(__global const float* raw, __global float* partial, uint N,
                                uint M, uint C, int act, uint parts) {
  const uint p = get_global_id(0);
  if (p >= parts) return;
  float s = 0.0f;
  for (uint m = p; m < M; m += parts) {
    float b = 0.0f;
    for (uint n = 0; n < N; ++n) b += nova_blend(raw[((size_t)n * M + m) * C + 4], act);
    s += fabs(b - 1.0f);
  }
  partial[p] = s;
}

// One work-item per raw element: the blend channel gets gloss * scale * sign(sum - 1) *
// blend', every other channel 0 (the loss does not read it). sign(0) = 0.
__kernel void blend_sum_backward(__global const float* raw, __global const float* gloss,
                                 __global float* grad, uint N, uint M, uint C, int act,
                                 float scale, int accumulate) {
  const uint e = get_global_id(0);
  if (e >= N * M * C) return;
  float g = 0.0f;
  if (e % C == 4) {
    const uint m = (e / C) % M;
    float b = 0.0f;
    for (uint n = 0; n < N; ++n) b += nova_blend(raw[((size_t)n * M + m) * C + 4], act);
    const float mine = nova_blend(raw[e], act);
    g = gloss[0] * scale * sign(b - 1.0f) * nova_blend_slope(mine, act);
  }
  grad[e] = accumulate ? grad[e] + g : g;
}

// Alpha loss over the object NeRFs n >= 1, raw [N, R*S, C], delta [R, S] or [N, R, S]
// (delta_stride 0 or R*S), noise [N, R, S] (use_noise), mask [N, R]:
// partial[p] = sum over (n >= 1, r, i) = p, p + parts, ... of
//   c_out (1 - mask_n(r)) (alpha + blend) + c_in mask_n(r) alpha,
// alpha = 1 - exp(-ReLU(sigma + noise) delta). (1, 0) is the alpha loss; (0, 1) the sparsity
// loss, an L1 on alpha inside the mask: for a given opacity 1 - prod(1 - alpha_i), sum alpha_i
// is smallest when one sample holds it, so it favours one compact surface per ray.
__kernel void alpha_outside_partial(__global const float* raw, __global const float* delta,
                                    __global const float* noise, __global const float* mask,
                                    __global float* partial, uint N, uint R, uint S, uint C,
                                    uint delta_stride, int use_noise, int act, float c_out,
                                    float c_in, uint parts) {
  const uint p = get_global_id(0);
  if (p >= parts) return;
  const uint rs = R * S, n_items = (N - 1) * rs;
  float s = 0.0f;
  for (uint q = p; q < n_items; q += parts) {
    const uint e = rs + q;  // skips NeRF 0
    const uint n = e / rs, at = e % rs;
    const float outside = 1.0f - mask[n * R + at / S];
    const float alpha = nova_alpha(raw[(size_t)e * C + 3] + (use_noise ? noise[e] : 0.0f), delta[n * delta_stride + at]);
    const float blend = c_out != 0.0f ? nova_blend(raw[(size_t)e * C + 4], act) : 0.0f;
    s += c_out * outside * (alpha + blend) + c_in * (1.0f - outside) * alpha;
  }
  partial[p] = s;
}

__kernel void alpha_outside_backward(__global const float* raw, __global const float* delta,
                                     __global const float* noise, __global const float* mask,
                                     __global const float* gloss, __global float* grad, uint N,
                                     uint R, uint S, uint C, uint delta_stride, int use_noise,
                                     int act, float c_out, float c_in, float scale,
                                     int accumulate) {
  const uint e = get_global_id(0);
  if (e >= N * R * S * C) return;
  const uint sample = e / C, ch = e % C, rs = R * S;
  const uint n = sample / rs, at = sample % rs;
  float g = 0.0f;
  if (n >= 1 && (ch == 3 || ch == 4)) {
    const float outside = 1.0f - mask[n * R + at / S];
    const float w = gloss[0] * scale * c_out * outside;
    if (ch == 3) {
      const float wa = gloss[0] * scale * (c_out * outside + c_in * (1.0f - outside));
      const float s = raw[e] + (use_noise ? noise[sample] : 0.0f);
      const float d = delta[n * delta_stride + at];
      const float t = nova_transmittance(s, d);
      // d alpha / d sigma = delta exp(-sigma delta), 0 once exp underflows, 0 below the ReLU.
      g = s > 0.0f && t > 0.0f ? wa * t * d : 0.0f;
    } else if (w != 0.0f) {
      g = w * nova_blend_slope(nova_blend(raw[e], act), act);
    }
  }
  grad[e] = accumulate ? grad[e] + g : g;
}

// Distortion loss (Barron et al. 2022, mip-NeRF 360), per NeRF with its own transmittance:
// for NeRF n and ray r, with sample weights w_i = T_i alpha_i (T_i = prod_{j<i} (1 - alpha_j),
// alpha = 1 - exp(-ReLU(sigma + noise) delta)) at normalised depths
// u_i = (z_i - z_0) / (z_{S-1} - z_0) in [0, 1],
//   L_nr = sum_{i,j} w_i w_j |u_i - u_j| = 2 sum_i w_i (u_i W_<i - WU_<i),
// W_<i = sum_{j<i} w_j and WU_<i = sum_{j<i} w_j u_j (z increases along the ray). It is 0
// when one sample holds the ray's weight and grows with the spread: a haze or a streak of
// density along the ray costs, one surface does not.
//
// Layout: raw [N, R*S, C] (sigma in channel 3), delta [R, S] or [N, R, S] (delta_stride 0 or
// R*S), z [R, S], noise [N, R*S] (use_noise), mask [N, R] (use_mask; else every ray counts).
// NeRFs below `first` are left out (their gradient is 0). One work-item per (NeRF, ray): S is
// small and the walk is sequential.


inline float dl_u(__global const float* zr, uint i, uint S) {
  const float span = zr[S - 1] - zr[0];
  return span > 0.0f ? (zr[i] - zr[0]) / span : 0.0f;
}

// partial[n * R + r] = mask_n(r) L_nr.
__kernel void distortion_partial(__global const float* raw, __global const float* delta,
                                 __global const float* z, __global const float* noise,
                                 __global const float* mask, __global float* partial, uint N,
                                 uint R, uint S, uint C, uint delta_stride, int use_noise,
                                 int use_mask, uint first) {
  const uint nr = get_global_id(0);
  if (nr >= N * R) return;
  const uint n = nr / R, r = nr % R;
  const float m = n < first ? 0.0f : use_mask ? mask[nr] : 1.0f;
  if (m == 0.0f) {
    partial[nr] = 0.0f;
    return;
  }
  __global const float* zr = z + (size_t)r * S;
  float T = 1.0f, W = 0.0f, WU = 0.0f, L = 0.0f;
  for (uint i = 0; i < S; ++i) {
    const size_t e = (size_t)n * R * S + (size_t)r * S + i;
    const float s = raw[e * C + 3] + (use_noise ? noise[e] : 0.0f);
    const float a = nova_alpha(s, delta[n * delta_stride + r * S + i]);
    const float w = T * a, u = dl_u(zr, i, S);
    L += w * (u * W - WU);
    W += w;
    WU += w * u;
    T *= 1.0f - a;
  }
  partial[nr] = m * 2.0f * L;
}

// d raw: only sigma (channel 3) carries a gradient; the other channels get 0. With
// g_i = dL/dw_i = 2 sum_j w_j |u_i - u_j| and A_i = sum_{k>i} g_k alpha_k prod_{i<j<k}
// (1 - alpha_j) (A_{i-1} = g_i alpha_i + (1 - alpha_i) A_i), dL/dalpha_i = T_i (g_i - A_i):
// no division by 1 - alpha, so opaque samples are exact. `work` holds w and T of the
// forward walk ([N*R*S] each).
__kernel void distortion_backward(__global const float* raw, __global const float* delta,
                                  __global const float* z, __global const float* noise,
                                  __global const float* mask, __global const float* gloss,
                                  __global float* work, __global float* grad, uint N, uint R,
                                  uint S, uint C, uint delta_stride, int use_noise,
                                  int use_mask, uint first_nerf, float scale, int accumulate) {
  const uint nr = get_global_id(0);
  if (nr >= N * R) return;
  const uint n = nr / R, r = nr % R;
  const size_t first = (size_t)n * R * S + (size_t)r * S;
  const float coef =
      n < first_nerf ? 0.0f : gloss[0] * scale * (use_mask ? mask[nr] : 1.0f);
  __global const float* zr = z + (size_t)r * S;
  __global float* ws = work + first;
  __global float* ts = work + (size_t)N * R * S + first;

  float T = 1.0f, W = 0.0f, WU = 0.0f;
  for (uint i = 0; i < S; ++i) {
    const float s = raw[(first + i) * C + 3] + (use_noise ? noise[first + i] : 0.0f);
    const float a = nova_alpha(s, delta[n * delta_stride + r * S + i]);
    ts[i] = T;
    ws[i] = T * a;
    W += T * a;
    WU += T * a * dl_u(zr, i, S);
    T *= 1.0f - a;
  }

  float W_after = 0.0f, WU_after = 0.0f, A = 0.0f;
  for (uint k = S; k-- > 0;) {
    const size_t e = first + k;
    const float s = raw[e * C + 3] + (use_noise ? noise[e] : 0.0f);
    const float d = delta[n * delta_stride + r * S + k];
    const float a = nova_alpha(s, d);
    const float u = dl_u(zr, k, S), w = ws[k];
    const float W_before = W - W_after - w, WU_before = WU - WU_after - w * u;
    const float g = 2.0f * (u * W_before - WU_before + WU_after - u * W_after);
    const float t = nova_transmittance(s, d);
    // d alpha / d raw = delta exp(-sigma delta) above the ReLU; 0 once exp underflows.
    const float dsig = s > 0.0f && t > 0.0f ? coef * ts[k] * (g - A) * t * d : 0.0f;
    for (uint c = 0; c < C; ++c) {
      const float v = c == 3 ? dsig : 0.0f;
      grad[e * C + c] = accumulate ? grad[e * C + c] + v : v;
    }
    A = g * a + (1.0f - a) * A;
    W_after += w;
    WU_after += w * u;
  }
}

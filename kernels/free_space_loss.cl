// Free-space loss: the disparity says where each ray's first surface is; samples well in front
// of it are empty space. The target z*_r = a + b t_r maps the target into the units of the
// rendered depth p by a least-squares fit of p on t over the valid background rays (mask row
// 0), where the static NeRF, pretrained on such pixels, gives a depth to trust; on object
// rays p is not (a hazy object renders a small p). A constant here: p gets no gradient. For
// NeRF n >= first on ray r, with its own weights w_i = T_i alpha_i and
// h_i = max(0, z*_r - margin - z_i) + behind max(0, z_i - z*_r - margin) (a, b from
// free_space_fit):
//   partial[n R + r] = valid_r mask_n(r) sum_i w_i h_i.
// With behind > 0 weight more than the margin *behind* the surface costs too: from the one
// camera that sees an object at a time, an object pushed back along its rays renders the same
// image, so only this term holds it at the disparity's depth (seen from elsewhere it shifts).
// Unlike the depth loss on the expected depth, this sees a haze in front of a surface even
// where the expected depth is right, and unlike the distortion loss it sees a compact layer
// at the wrong depth. Layout as kernels/distortion_loss.cl (raw [N, R*S, C], sigma in channel 3).

// Keeps the fit's slope finite where t is constant over its rays; the value of the depth
// loss's DEPTH_EPS (kernels/depth_loss.cl), so both regularise alike.
#define FIT_EPS 1e-6f

// h of sample depth zi for the surface at zs (= z*_r): distance beyond the margin, in front
// with weight 1 and behind with weight `behind`.
inline float fs_cost(float zs, float zi, float margin, float behind) {
  return fmax(zs - margin - zi, 0.0f) + (behind != 0.0f ? behind * fmax(zi - zs - margin, 0.0f) : 0.0f);
}

// work[at .. at + 3) = (a, b, n) of the least-squares fit p ~ a + b t over the rays with
// valid[r] mask[r] (mask row 0); n < 2: no fit. Once per pass, one work-item's fixed-order
// sums (as depth_moments in kernels/depth_loss.cl), read by every (NeRF, ray) item of the
// pass: it follows the N R partial sums in the forward's workspace and the N R S
// transmittances in the backward's.
__kernel void free_space_fit(__global const float* p, __global const float* t,
                             __global const float* valid, __global const float* mask,
                             __global float* work, uint at, uint R) {
  if (get_global_id(0) != 0) return;
  __global float* fit = work + at;
  float n = 0.0f, sp = 0.0f, st = 0.0f;
  for (uint r = 0; r < R; ++r) {
    const float w = valid[r] * mask[r];
    n += w;
    sp += w * p[r];
    st += w * t[r];
  }
  fit[0] = 0.0f;
  fit[1] = 0.0f;
  fit[2] = n;
  if (n < 2.0f) return;
  const float mp = sp / n, mt = st / n;
  float cov = 0.0f, vt = 0.0f;
  for (uint r = 0; r < R; ++r) {
    const float w = valid[r] * mask[r], dt = t[r] - mt;
    cov += w * (p[r] - mp) * dt;
    vt += w * dt * dt;
  }
  const float b = cov / (vt + FIT_EPS * n);
  fit[0] = mp - b * mt;
  fit[1] = b;
}

// The fit of a target that already is the surface in the rendered depth's units (the scene's
// disparity placed once for the whole video): z* = 0 + 1 t.
__kernel void free_space_fit_identity(__global float* work, uint at, uint R) {
  if (get_global_id(0) != 0) return;
  work[at] = 0.0f;
  work[at + 1] = 1.0f;
  work[at + 2] = (float)R;
}

__kernel void free_space_partial(__global const float* raw, __global const float* delta,
                                 __global const float* z, __global const float* t,
                                 __global const float* valid, __global const float* mask,
                                 __global const float* noise, __global float* partial, uint N,
                                 uint R, uint S, uint C, uint delta_stride, int use_noise,
                                 uint first, float margin, float behind) {
  const uint nr = get_global_id(0);
  if (nr >= N * R) return;
  __global const float* fit = partial + N * R;
  const uint n = nr / R, r = nr % R;
  const float m = n < first || fit[2] < 2.0f ? 0.0f : valid[r] * mask[nr];
  if (m == 0.0f) {
    partial[nr] = 0.0f;
    return;
  }
  const float zs = fit[0] + fit[1] * t[r];
  float T = 1.0f, L = 0.0f;
  for (uint i = 0; i < S; ++i) {
    const size_t e = (size_t)n * R * S + (size_t)r * S + i;
    const float a = nova_alpha(raw[e * C + 3] + (use_noise ? noise[e] : 0.0f),
                             delta[n * delta_stride + r * S + i]);
    L += T * a * fs_cost(zs, z[(size_t)r * S + i], margin, behind);
    T *= 1.0f - a;
  }
  partial[nr] = m * L;
}

// d raw (sigma only): dL/dalpha_i = T_i (h_i - A_i), A_i = sum_{k>i} h_k alpha_k
// prod_{i<j<k} (1 - alpha_j), walked backwards (A_{i-1} = h_i alpha_i + (1 - alpha_i) A_i);
// `work` keeps the forward walk's T ([N*R*S]), then the fit. Work-items nr < R also clear dp (the rendered
// depth gets no gradient from this loss) when they are its first writer.
__kernel void free_space_backward(__global const float* raw, __global const float* delta,
                                  __global const float* z, __global const float* t,
                                  __global const float* valid, __global const float* mask,
                                  __global const float* noise, __global const float* gloss,
                                  __global float* work,
                                  __global float* grad, __global float* dp, uint N, uint R,
                                  uint S, uint C, uint delta_stride, int use_noise, uint first,
                                  float margin, float behind, float scale, int accumulate,
                                  int clear_dp) {
  const uint nr = get_global_id(0);
  if (nr >= N * R) return;
  if (clear_dp && nr < R) dp[nr] = 0.0f;
  const uint n = nr / R, r = nr % R;
  __global const float* fit = work + (size_t)N * R * S;
  const float coef = n < first || fit[2] < 2.0f ? 0.0f : gloss[0] * scale * valid[r] * mask[nr];
  const float zs = fit[0] + fit[1] * t[r];
  const size_t first_e = (size_t)n * R * S + (size_t)r * S;
  __global float* ts = work + first_e;
  float T = 1.0f;
  for (uint i = 0; i < S; ++i) {
    ts[i] = T;
    T *= 1.0f - nova_alpha(raw[(first_e + i) * C + 3] + (use_noise ? noise[first_e + i] : 0.0f),
                         delta[n * delta_stride + r * S + i]);
  }
  float A = 0.0f;
  for (uint k = S; k-- > 0;) {
    const size_t e = first_e + k;
    const float s = raw[e * C + 3] + (use_noise ? noise[e] : 0.0f);
    const float d = delta[n * delta_stride + r * S + k];
    const float a = nova_alpha(s, d), h = fs_cost(zs, z[(size_t)r * S + k], margin, behind);
    const float ex = nova_transmittance(s, d);
    // d alpha / d raw = delta exp(-sigma delta) above the ReLU; 0 once exp underflows.
    const float dsig = s > 0.0f && ex > 0.0f && coef != 0.0f ? coef * ts[k] * (h - A) * ex * d : 0.0f;
    for (uint c = 0; c < C; ++c) {
      const float v = c == 3 ? dsig : 0.0f;
      grad[e * C + c] = accumulate ? grad[e * C + c] + v : v;
    }
    A = h * a + (1.0f - a) * A;
  }
}

// Multi-NeRF compositing with per-sample blending factors (NOVA / DynamicNeRF style), one
// work-item per ray, forward and backward.
//
// Build options:
//   NERFS          number of NeRFs rendered together (1 static + K objects), 1..16
//   RGB_SIGMOID    1: the rgb channels are raw and get a sigmoid here; 0: already in [0, 1]
//   BLEND_SIGMOID  1: the blend channel is raw and gets a sigmoid here; 0: already activated
//   HARD_BLEND     1: the static blend (NeRF 0) becomes 0 wherever an object blend > 0.5
//   BLEND_EPS      epsilon of the blend normalisation (default 1e-6f; the reference's 1e-8f)
//   ALPHA_FULL_SUM 1: alpha_full_i = sum_n alpha_n b_n (the reference code's weights_full)
//                  in mask, depth and acc; 0: 1 - P_i
//   NO_BLEND       1: b_n = 1 (plain NeRF compositing; the blend channel gets no gradient)
//   NERF_DEPTH     1: also write nerf_depth [N, R] = sum_i T^n_i alpha_n z_i
//
// Layouts (R rays, S samples per ray, N = NERFS, C >= 5 channels per sample):
//   raw    [N, R, S, C]  channels 0..2 rgb, 3 sigma (raw: ReLU(sigma + noise) here), 4 blend
//   delta  [R, S] or [N, R, S] (delta_stride 0 or R*S): spacing, already times |d|, the last
//          sample of a ray 1e10 * |d| as the reference code does
//   z      [R, S] sample depth (NDC t or metric), only for the expected depth
//   noise  [N, R, S] added to sigma before the ReLU (use_noise 0: ignored)
// Outputs: rgb [R, 3], nerf_rgb [N, R, 3], mask [N, R], depth [R], acc [R].
//
// Per sample i and NeRF n: alpha_n = 1 - exp(-sigma_n delta_n) (as -expm1, exact for tiny
// sigma delta), b_n = blend_n / (sum_m blend_m + BLEND_EPS), q_n = 1 - alpha_n b_n,
// P_i = prod_n q_n, alpha_full_i = 1 - P_i, T_0 = 1, T_{i+1} = T_i (P_i + TRANS_EPS).
//   rgb      = sum_i T_i sum_n alpha_n b_n c_n
//   mask_n   = sum_i T_i alpha_full_i b_n
//   depth    = sum_i T_i alpha_full_i z_i,  acc = sum_i T_i alpha_full_i
//   nerf_rgb_n = sum_i T^n_i alpha_n c_n with T^n_{i+1} = T^n_i (1 - alpha_n + TRANS_EPS):
//   NeRF n alone, without blending (DynamicNeRF's rgb_map_d).
// alpha_full is accumulated as a union of probabilities (A += P_prev alpha_n b_n), never as
// 1 - P, so that a nearly transparent sample keeps its relative precision.

#ifndef NERFS
#define NERFS 1
#endif
#ifndef RGB_SIGMOID
#define RGB_SIGMOID 1
#endif
#ifndef BLEND_SIGMOID
#define BLEND_SIGMOID 1
#endif
#ifndef HARD_BLEND
#define HARD_BLEND 0
#endif
#ifndef ALPHA_FULL_SUM
#define ALPHA_FULL_SUM 0
#endif
#ifndef NO_BLEND
#define NO_BLEND 0
#endif
#ifndef NERF_DEPTH
#define NERF_DEPTH 0
#endif

// The reference's +1e-10 inside the transmittance product.
#define TRANS_EPS 1e-10f
// Keeps b_n / sum(b) finite when every blend is 0 (the sample then adds no density).
#ifndef BLEND_EPS
#define BLEND_EPS 1e-6f
#endif

// 1 / (sum_n blend_n + eps): b_n = blend_n times this (1 without blending).
inline float blend_norm(float bsum) {
#if NO_BLEND
  return 1.0f;
#else
  return 1.0f / (bsum + BLEND_EPS);
#endif
}

// NeRF n's step through a sample's blended opacity: A, the sample's mask (1 - prod(1 - a b)
// built up as sum P a b, or with ALPHA_FULL_SUM the plain sum of a b), and P, the product of
// (1 - a b) so far; returns a b. The forward and the backward's replay share it.
inline float blend_step(float alpha, float b, float* A, float* P) {
  const float ab = alpha * b;
#if ALPHA_FULL_SUM
  *A += ab;
#else
  *A += *P * ab;
#endif
  *P *= 1.0f - ab;
  return ab;
}

// Everything one sample of one NeRF contributes, with the derivatives of the activations.
typedef struct {
  float alpha;    // 1 - exp(-sigma delta)
  float trans;    // exp(-sigma delta) = 1 - alpha, computed directly
  float dadraw;   // d alpha / d raw sigma
  float blend;    // activated, before normalisation
  float dbdraw;   // d blend / d raw blend
  float c[3];     // activated colour
  float dcdraw[3];
} SampleTerms;

inline SampleTerms sample_terms(__global const float* p, float delta, float noise) {
  SampleTerms t;
  const float s = p[3] + noise;
  t.alpha = nova_alpha(s, delta);
  t.trans = nova_transmittance(s, delta);
  // d alpha / d sigma = delta exp(-sigma delta); written as a product that is 0 (not 0 * inf)
  // once the exponential underflows, whatever delta is.
  t.dadraw = s > 0.0f ? (t.trans > 0.0f ? t.trans * delta : 0.0f) : 0.0f;
#if NO_BLEND
  t.blend = 1.0f;
  t.dbdraw = 0.0f;
#elif BLEND_SIGMOID
  t.blend = NOVA_SIGMOID(p[4]);
  t.dbdraw = t.blend * (1.0f - t.blend);
#else
  t.blend = p[4];
  t.dbdraw = 1.0f;
#endif
  for (int k = 0; k < 3; ++k) {
#if RGB_SIGMOID
    t.c[k] = NOVA_SIGMOID(p[k]);
    t.dcdraw[k] = t.c[k] * (1.0f - t.c[k]);
#else
    t.c[k] = p[k];
    t.dcdraw[k] = 1.0f;
#endif
  }
  return t;
}

// Loads the terms of all NeRFs at (ray r, sample i) and applies hard blending.
inline void load_sample(__global const float* raw, __global const float* delta,
                        __global const float* noise, uint R, uint S, uint C, uint delta_stride,
                        int use_noise, uint r, uint i, SampleTerms* t) {
  const size_t rs = (size_t)R * S, at = (size_t)r * S + i;
  for (int n = 0; n < NERFS; ++n) {
    const float nz = use_noise ? noise[n * rs + at] : 0.0f;
    t[n] = sample_terms(raw + (n * rs + at) * C, delta[n * (size_t)delta_stride + at], nz);
  }
#if HARD_BLEND
  bool object_wins = false;
  for (int n = 1; n < NERFS; ++n) object_wins = object_wins || t[n].blend > 0.5f;
  if (object_wins) {
    t[0].blend = 0.0f;
    t[0].dbdraw = 0.0f;
  }
#endif
}

__kernel void render_forward(__global const float* raw, __global const float* delta,
                             __global const float* z, __global const float* noise,
                             __global float* rgb, __global float* nerf_rgb,
                             __global float* mask, __global float* depth, __global float* acc,
                             __global float* nerf_depth, uint R, uint S, uint C,
                             uint delta_stride, int use_noise) {
  const uint r = get_global_id(0);
  if (r >= R) return;
  SampleTerms t[NERFS];
  float T = 1.0f, Tn[NERFS];
  float col[3] = {0.0f, 0.0f, 0.0f}, d = 0.0f, a = 0.0f;
  float m[NERFS], cn[NERFS][3];
#if NERF_DEPTH
  float dn[NERFS];
  for (int n = 0; n < NERFS; ++n) dn[n] = 0.0f;
#endif
  for (int n = 0; n < NERFS; ++n) {
    Tn[n] = 1.0f;
    m[n] = 0.0f;
    cn[n][0] = cn[n][1] = cn[n][2] = 0.0f;
  }
  for (uint i = 0; i < S; ++i) {
    load_sample(raw, delta, noise, R, S, C, delta_stride, use_noise, r, i, t);
    float bsum = 0.0f;
    for (int n = 0; n < NERFS; ++n) bsum += t[n].blend;
    const float inv = blend_norm(bsum);
    float P = 1.0f, A = 0.0f;
    for (int n = 0; n < NERFS; ++n) {
      const float ab = blend_step(t[n].alpha, t[n].blend * inv, &A, &P);
      for (int k = 0; k < 3; ++k) col[k] += T * ab * t[n].c[k];
      // The NeRF alone, with its own transmittance.
      const float w = Tn[n] * t[n].alpha;
      for (int k = 0; k < 3; ++k) cn[n][k] += w * t[n].c[k];
#if NERF_DEPTH
      dn[n] += w * z[(size_t)r * S + i];
#endif
      Tn[n] *= t[n].trans + TRANS_EPS;
    }
    const float w = T * A;
    for (int n = 0; n < NERFS; ++n) m[n] += w * t[n].blend * inv;
    d += w * z[(size_t)r * S + i];
    a += w;
    T *= P + TRANS_EPS;
  }
  for (int k = 0; k < 3; ++k) rgb[r * 3 + k] = col[k];
  for (int n = 0; n < NERFS; ++n) {
    mask[(size_t)n * R + r] = m[n];
    for (int k = 0; k < 3; ++k) nerf_rgb[((size_t)n * R + r) * 3 + k] = cn[n][k];
#if NERF_DEPTH
    nerf_depth[(size_t)n * R + r] = dn[n];
#endif
  }
  depth[r] = d;
  acc[r] = a;
}

// Backward. With L = sum_i T_i h_i, T_{i+1} = T_i f_i, the reverse scan carries
// Rs_i = sum_{k > i} (T_k / T_{i+1}) h_k (Rs_{i-1} = h_i + f_i Rs_i), so that
// dL/df_i = T_i Rs_i without dividing by f_i (which may be 1e-10). T_i and T^n_i come from a
// first, forward scan into `work` [(N + 1), R, S].
//
// grad_mask bit k says whether the upstream gradient of output k exists (rgb 1, nerf_rgb 2,
// mask 4, depth 8, acc 16, nerf_depth 32); missing ones are zero.
__kernel void render_backward(__global const float* raw, __global const float* delta,
                              __global const float* z, __global const float* noise,
                              __global const float* g_rgb, __global const float* g_nerf_rgb,
                              __global const float* g_mask, __global const float* g_depth,
                              __global const float* g_acc, __global const float* g_nerf_depth,
                              __global float* g_raw,
                              __global float* work, uint R, uint S, uint C, uint delta_stride,
                              int use_noise, int grad_mask, int accumulate) {
  const uint r = get_global_id(0);
  if (r >= R) return;
  const size_t rs = (size_t)R * S;
  SampleTerms t[NERFS];

  // Upstream gradients of this ray.
  float gc[3] = {0.0f, 0.0f, 0.0f}, gn[NERFS][3], gm[NERFS];
  const float gd = (grad_mask & 8) ? g_depth[r] : 0.0f;
  const float ga = (grad_mask & 16) ? g_acc[r] : 0.0f;
  for (int k = 0; k < 3; ++k) gc[k] = (grad_mask & 1) ? g_rgb[r * 3 + k] : 0.0f;
#if NERF_DEPTH
  float gdn[NERFS];
  for (int n = 0; n < NERFS; ++n) gdn[n] = (grad_mask & 32) ? g_nerf_depth[(size_t)n * R + r] : 0.0f;
#endif
  for (int n = 0; n < NERFS; ++n) {
    gm[n] = (grad_mask & 4) ? g_mask[(size_t)n * R + r] : 0.0f;
    for (int k = 0; k < 3; ++k)
      gn[n][k] = (grad_mask & 2) ? g_nerf_rgb[((size_t)n * R + r) * 3 + k] : 0.0f;
  }

  // Forward scan: transmittances before each sample.
  {
    float T = 1.0f, Tn[NERFS];
    for (int n = 0; n < NERFS; ++n) Tn[n] = 1.0f;
    for (uint i = 0; i < S; ++i) {
      load_sample(raw, delta, noise, R, S, C, delta_stride, use_noise, r, i, t);
      const size_t at = (size_t)r * S + i;
      work[at] = T;
      float bsum = 0.0f;
      for (int n = 0; n < NERFS; ++n) bsum += t[n].blend;
      const float inv = blend_norm(bsum);
      float P = 1.0f;
      for (int n = 0; n < NERFS; ++n) {
        work[(n + 1) * rs + at] = Tn[n];
        P *= 1.0f - t[n].alpha * t[n].blend * inv;
        Tn[n] *= t[n].trans + TRANS_EPS;
      }
      T *= P + TRANS_EPS;
    }
  }

  // Reverse scan.
  float Rs = 0.0f, Rn[NERFS];
  for (int n = 0; n < NERFS; ++n) Rn[n] = 0.0f;
  for (uint ii = S; ii > 0; --ii) {
    const uint i = ii - 1;
    const size_t at = (size_t)r * S + i;
    load_sample(raw, delta, noise, R, S, C, delta_stride, use_noise, r, i, t);
    const float T = work[at];
    float bsum = 0.0f;
    for (int n = 0; n < NERFS; ++n) bsum += t[n].blend;
    const float inv = blend_norm(bsum);

    float b[NERFS], q[NERFS], gcc[NERFS];
    float A = 0.0f, P = 1.0f, G = gd * z[at] + ga;
    for (int n = 0; n < NERFS; ++n) {
      b[n] = t[n].blend * inv;
      q[n] = 1.0f - blend_step(t[n].alpha, b[n], &A, &P);
      gcc[n] = gc[0] * t[n].c[0] + gc[1] * t[n].c[1] + gc[2] * t[n].c[2];
      G += gm[n] * b[n];
    }
    // dP/dq_n = prod_{m != n} q_m from prefix and suffix products (no division by q_n = 0).
    float pre[NERFS], suf = 1.0f, dPdq[NERFS];
    pre[0] = 1.0f;
    for (int n = 1; n < NERFS; ++n) pre[n] = pre[n - 1] * q[n - 1];
    for (int n = NERFS - 1; n >= 0; --n) {
      dPdq[n] = pre[n] * suf;
      suf *= q[n];
    }
    // h_i = gc . sum_n a_n b_n c_n + A G; dL/dP = T (Rs - G) (P enters h as -P and f as +P).
    // With ALPHA_FULL_SUM, A = sum_n a_n b_n does not involve P: dL/dP = T Rs, and A G
    // adds T G b_n to dL/da_n and T G a_n to dL/db_n.
#if ALPHA_FULL_SUM
    const float gP = T * Rs;
#else
    const float gP = T * (Rs - G);
#endif
    float h = A * G;
    float gb[NERFS];
    for (int n = 0; n < NERFS; ++n) {
      h += t[n].alpha * b[n] * gcc[n];
      // Composite part.
      float g_alpha = T * b[n] * gcc[n] - gP * dPdq[n] * b[n];
      gb[n] = T * (t[n].alpha * gcc[n] + A * gm[n]) - gP * dPdq[n] * t[n].alpha;
#if ALPHA_FULL_SUM
      g_alpha += T * G * b[n];
      gb[n] += T * G * t[n].alpha;
#endif
      float gcol[3];
      for (int k = 0; k < 3; ++k) gcol[k] = T * t[n].alpha * b[n] * gc[k];
      // The NeRF alone: L_n = sum_i T^n_i a_n (gn . c_n [+ gdn z_i]), f^n_i = 1 - a_n + eps.
      const float Tn = work[(n + 1) * rs + at];
#if NERF_DEPTH
      const float gnc = gn[n][0] * t[n].c[0] + gn[n][1] * t[n].c[1] + gn[n][2] * t[n].c[2] +
                        gdn[n] * z[at];
#else
      const float gnc = gn[n][0] * t[n].c[0] + gn[n][1] * t[n].c[1] + gn[n][2] * t[n].c[2];
#endif
      g_alpha += Tn * (gnc - Rn[n]);
      for (int k = 0; k < 3; ++k) gcol[k] += Tn * t[n].alpha * gn[n][k];
      Rn[n] = t[n].alpha * gnc + (t[n].trans + TRANS_EPS) * Rn[n];

      __global float* g = g_raw + (n * rs + at) * C;
      const float vals[4] = {gcol[0] * t[n].dcdraw[0], gcol[1] * t[n].dcdraw[1],
                             gcol[2] * t[n].dcdraw[2], g_alpha * t[n].dadraw};
      for (int k = 0; k < 4; ++k) g[k] = accumulate ? g[k] + vals[k] : vals[k];
    }
    // Through the normalisation b_n = blend_n / (sum + eps), then the blend activation:
    // dL/dblend_n = (gb_n - sum_m gb_m b_m) inv, computed as sum_{m != n} (gb_n - gb_m) b_m +
    // gb_n eps inv (since 1 - sum_m b_m = eps inv). Where b_n is within eps of 1 (a NeRF alone,
    // as in pretraining, or one whose blend dominates) the direct difference cancels to a few
    // ulps of gb_n, about 3% noise per sample with eps 1e-6; Adam, normalising a gradient that
    // small, turns the noise into full-size steps that change with the order the weight
    // gradients are summed in (ranks, BLAS kernels).
    for (int n = 0; n < NERFS; ++n) {
      float gnorm = gb[n] * BLEND_EPS * inv;
      for (int m = 0; m < NERFS; ++m)
        if (m != n) gnorm += (gb[n] - gb[m]) * b[m];
      const float gblend = gnorm * inv * t[n].dbdraw;
      __global float* g = g_raw + (n * rs + at) * C;
      g[4] = accumulate ? g[4] + gblend : gblend;
      for (uint k = 5; k < C; ++k)
        if (!accumulate) g[k] = 0.0f;
    }
    Rs = h + (P + TRANS_EPS) * Rs;
  }
}

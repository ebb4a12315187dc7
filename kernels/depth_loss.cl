// Depth up to scale and shift: rendered depth p and target t (anything affine in depth with a
// positive slope, e.g. minus the disparity in NDC) are each standardised over the valid rays,
// x^ = (x - mean) / sqrt(var + eps), and the loss is mean over valid rays of (p^ - t^)^2,
// i.e. 2 (1 - correlation) for eps -> 0. Monocular disparity (MiDaS-like, or exact on
// synthetic scenes) is only known up to such a map, as in DynamicNeRF's depth loss.
//
// R is one batch of rays (<= a few thousand): one work-item runs the sums in a fixed order,
// which costs microseconds and keeps runs bit-reproducible.

#define DEPTH_EPS 1e-6f

typedef struct {
  float n, mp, mt, sp, st;
} depth_stats;

inline depth_stats depth_moments(__global const float* p, __global const float* t,
                                 __global const float* valid, uint R) {
  depth_stats s = {0.0f, 0.0f, 0.0f, 1.0f, 1.0f};
  float n = 0.0f, sp = 0.0f, st = 0.0f;
  for (uint r = 0; r < R; ++r) {
    n += valid[r];
    sp += valid[r] * p[r];
    st += valid[r] * t[r];
  }
  if (n < 2.0f) return s;
  s.n = n;
  s.mp = sp / n;
  s.mt = st / n;
  float vp = 0.0f, vt = 0.0f;
  for (uint r = 0; r < R; ++r) {
    const float dp = p[r] - s.mp, dt = t[r] - s.mt;
    vp += valid[r] * dp * dp;
    vt += valid[r] * dt * dt;
  }
  s.sp = sqrt(vp / n + DEPTH_EPS);
  s.st = sqrt(vt / n + DEPTH_EPS);
  return s;
}

__kernel void depth_loss_forward(__global const float* p, __global const float* t,
                                 __global const float* valid, __global float* loss, uint R) {
  if (get_global_id(0) != 0) return;
  const depth_stats s = depth_moments(p, t, valid, R);
  float sum = 0.0f;
  if (s.n >= 2.0f)
    for (uint r = 0; r < R; ++r) {
      const float e = (p[r] - s.mp) / s.sp - (t[r] - s.mt) / s.st;
      sum += valid[r] * e * e;
    }
  loss[0] = s.n >= 2.0f ? sum / s.n : 0.0f;
}

// dL/dp_r = w_r / s_p (g_r - mean(g) - p^_r mean(g p^)), g_r = 2 w_r (p^_r - t^_r) / n, the
// means over the valid rays: the chain rule through the mean and the standard deviation.
__kernel void depth_loss_backward(__global const float* p, __global const float* t,
                                  __global const float* valid, __global const float* gloss,
                                  __global float* dp, uint R, int accumulate) {
  if (get_global_id(0) != 0) return;
  const depth_stats s = depth_moments(p, t, valid, R);
  float sg = 0.0f, sgp = 0.0f;
  if (s.n >= 2.0f)
    for (uint r = 0; r < R; ++r) {
      const float ph = (p[r] - s.mp) / s.sp, th = (t[r] - s.mt) / s.st;
      const float g = 2.0f * valid[r] * (ph - th) / s.n;
      sg += g;
      sgp += g * ph;
    }
  const float mg = s.n >= 2.0f ? sg / s.n : 0.0f, mgp = s.n >= 2.0f ? sgp / s.n : 0.0f;
  for (uint r = 0; r < R; ++r) {
    float d = 0.0f;
    if (s.n >= 2.0f && valid[r] != 0.0f) {
      const float ph = (p[r] - s.mp) / s.sp, th = (t[r] - s.mt) / s.st;
      const float g = 2.0f * valid[r] * (ph - th) / s.n;
      d = gloss[0] * valid[r] / s.sp * (g - mg - ph * mgp);
    }
    dp[r] = accumulate ? dp[r] + d : d;
  }
}

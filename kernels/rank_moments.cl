// Batch statistics of a batch split over ranks (data-parallel training, distributed.hpp):
// each rank sums over its own rays, the sums meet through rank_sum (host/ops/tensor/rank_sum.cpp),
// and the statistic is taken of the whole batch's sums, so every rank normalises as one
// process would. Two passes as the single-process kernels (depth_moments in depth_loss.cl,
// free_space_fit in free_space_loss.cl): first (sum w, sum w p, sum w t), then, about the whole
// batch's means, (sum w dp^2, sum w dt^2, sum w dp dt). w_r = valid_r, times mask_r with
// use_mask. R is one rank's rays: one work-item runs the sums in a fixed order.

// The constants of the single-process kernels (DEPTH_EPS, FIT_EPS), so a split batch
// regularises alike.
#define MOMENT_DEPTH_EPS 1e-6f
#define MOMENT_FIT_EPS 1e-6f

inline float moment_weight(__global const float* valid, __global const float* mask, uint r, int use_mask) {
  return use_mask ? valid[r] * mask[r] : valid[r];
}

// The whole batch's means from the first pass' sums; 0 below two rays (no statistic).
inline float2 moment_means(__global const float* first) {
  const float n = first[0];
  return n >= 2.0f ? (float2)(first[1] / n, first[2] / n) : (float2)(0.0f, 0.0f);
}

// out[0..3): the first pass' sums (centred = 0) or the second's about the means of `first`.
__kernel void moment_sums(__global const float* p, __global const float* t, __global const float* valid,
                          __global const float* mask, __global const float* first, __global float* out,
                          uint R, int use_mask, int centred) {
  if (get_global_id(0) != 0) return;
  float a = 0.0f, b = 0.0f, c = 0.0f;
  if (!centred) {
    for (uint r = 0; r < R; ++r) {
      const float w = moment_weight(valid, mask, r, use_mask);
      a += w;
      b += w * p[r];
      c += w * t[r];
    }
  } else {
    const float2 m = moment_means(first);
    for (uint r = 0; r < R; ++r) {
      const float w = moment_weight(valid, mask, r, use_mask), dp = p[r] - m.x, dt = t[r] - m.y;
      a += w * dp * dp;
      b += w * dt * dt;
      c += w * dp * dt;
    }
  }
  out[0] = a;
  out[1] = b;
  out[2] = c;
}

// d p (with write_p) and, for the second pass, d first (with write_first): the means are
// functions of first (m = first[1..2] / first[0]), so the second pass' gradient reaches them.
// t, valid and mask are data.
__kernel void moment_sums_backward(__global const float* p, __global const float* t,
                                   __global const float* valid, __global const float* mask,
                                   __global const float* first, __global const float* gout,
                                   __global float* dp, __global float* dfirst, uint R, int use_mask,
                                   int centred, int write_p, int accumulate_p, int write_first,
                                   int accumulate_first) {
  if (get_global_id(0) != 0) return;
  const float g0 = gout[0], g1 = gout[1], g2 = gout[2];
  const float2 m = centred ? moment_means(first) : (float2)(0.0f, 0.0f);
  float smp = 0.0f, smt = 0.0f;
  for (uint r = 0; r < R; ++r) {
    const float w = moment_weight(valid, mask, r, use_mask);
    float d = w * g1;
    if (centred) {
      const float ep = p[r] - m.x, et = t[r] - m.y;
      d = w * (2.0f * ep * g0 + et * g2);
      smp -= w * (2.0f * ep * g0 + et * g2);
      smt -= w * (2.0f * et * g1 + ep * g2);
    }
    if (write_p) dp[r] = accumulate_p ? dp[r] + d : d;
  }
  if (!write_first) return;
  float d0 = 0.0f, d1 = 0.0f, d2 = 0.0f;
  const float n = first[0];
  if (centred && n >= 2.0f) {
    d1 = smp / n;
    d2 = smt / n;
    d0 = -(smp * m.x + smt * m.y) / n;
  }
  dfirst[0] = accumulate_first ? dfirst[0] + d0 : d0;
  dfirst[1] = accumulate_first ? dfirst[1] + d1 : d1;
  dfirst[2] = accumulate_first ? dfirst[2] + d2 : d2;
}

// The depth loss (depth_loss.cl) of the whole batch from its moments: with a = VP / n,
// b = VT / n, c = C / n (second pass VP, VT, C), the mean of (p^ - t^)^2 over the valid rays is
// a / (a + eps) - 2 c / sqrt((a + eps)(b + eps)) + b / (b + eps); 0 below two valid rays.
__kernel void depth_loss_from_moments(__global const float* first, __global const float* second,
                                      __global float* loss) {
  if (get_global_id(0) != 0) return;
  const float n = first[0];
  if (n < 2.0f) {
    loss[0] = 0.0f;
    return;
  }
  const float vp = second[0] / n + MOMENT_DEPTH_EPS, vt = second[1] / n + MOMENT_DEPTH_EPS;
  loss[0] = (second[0] / vp - 2.0f * second[2] / (sqrt(vp) * sqrt(vt)) + second[1] / vt) / n;
}

// dL/da = eps / (a + eps)^2 + c / (sp^3 st), dL/db likewise, dL/dc = -2 / (sp st), sp = sqrt(a
// + eps), st = sqrt(b + eps); then through a = VP / n, b = VT / n, c = C / n.
__kernel void depth_loss_from_moments_backward(__global const float* first, __global const float* second,
                                               __global const float* gloss, __global float* dfirst,
                                               __global float* dsecond, int write_first,
                                               int accumulate_first, int write_second,
                                               int accumulate_second) {
  if (get_global_id(0) != 0) return;
  const float n = first[0];
  float d[4] = {0.0f, 0.0f, 0.0f, 0.0f};  // d n, d VP, d VT, d C
  if (n >= 2.0f) {
    const float a = second[0] / n, b = second[1] / n, c = second[2] / n;
    const float sp = sqrt(a + MOMENT_DEPTH_EPS), st = sqrt(b + MOMENT_DEPTH_EPS);
    const float la = MOMENT_DEPTH_EPS / ((a + MOMENT_DEPTH_EPS) * (a + MOMENT_DEPTH_EPS)) + c / (sp * sp * sp * st);
    const float lb = MOMENT_DEPTH_EPS / ((b + MOMENT_DEPTH_EPS) * (b + MOMENT_DEPTH_EPS)) + c / (sp * st * st * st);
    const float lc = -2.0f / (sp * st);
    const float g = gloss[0] / n;
    d[0] = -g * (a * la + b * lb + c * lc);
    d[1] = g * la;
    d[2] = g * lb;
    d[3] = g * lc;
  }
  if (write_first) {
    dfirst[0] = accumulate_first ? dfirst[0] + d[0] : d[0];
    for (int k = 1; k < 3; ++k) dfirst[k] = accumulate_first ? dfirst[k] : 0.0f;
  }
  if (write_second)
    for (int k = 0; k < 3; ++k) dsecond[k] = accumulate_second ? dsecond[k] + d[1 + k] : d[1 + k];
}

// The free-space loss' disparity fit (free_space_fit) of the whole batch from its moments
// (w = valid * mask row 0): work[at .. at + 3) = (a, b, n), n < 2: no fit.
__kernel void free_space_fit_from_moments(__global const float* first, __global const float* second,
                                          __global float* work, uint at) {
  if (get_global_id(0) != 0) return;
  __global float* fit = work + at;
  const float n = first[0];
  fit[0] = 0.0f;
  fit[1] = 0.0f;
  fit[2] = n;
  if (n < 2.0f) return;
  const float mp = first[1] / n, mt = first[2] / n;
  const float b = second[2] / (second[1] + MOMENT_FIT_EPS * n);
  fit[0] = mp - b * mt;
  fit[1] = b;
}

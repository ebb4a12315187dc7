#pragma once
// Float64 host references of the novel-view losses and the depth loss (losses.hpp), straight
// from their definitions, and the smooth raw fields the loss tests feed them. Shared by test_losses.cpp
// and the op table (op_table_losses.cpp).
#include <algorithm>
#include <cmath>
#include <vector>

#include "harness.hpp"

namespace nova::test {

inline double loss_sigmoid(double x) { return 1.0 / (1.0 + std::exp(-x)); }

// Raw [N, R*S, 5] with blend raw values in [1, 3] (so that sum_n sigmoid(blend) - 1 stays
// >= 0.46 away from the kink of |.| for N >= 2 and finite differences never cross it) and
// sigma raw values in +-[0.1, 2] (away from the ReLU kink by more than the FD step 1e-2).
inline std::vector<float> smooth_raw(size_t nerfs, size_t rs, unsigned seed) {
  auto raw = random_floats(nerfs * rs * 5, -2, 2, seed);
  const auto u = random_floats(nerfs * rs * 2, 0, 1, seed + 1);
  for (size_t s = 0; s < nerfs * rs; ++s) {
    raw[s * 5 + 4] = 1.0f + 2.0f * u[2 * s];
    const float mag = 0.1f + 1.9f * u[2 * s + 1];
    raw[s * 5 + 3] = (s % 3 == 0) ? -mag : mag;
  }
  return raw;
}

// Float64 references, straight from the definitions in losses.hpp.
inline double ref_masked_mse(const std::vector<float>& pred, const std::vector<float>& target,
                      const std::vector<float>& mask, size_t G, size_t R, size_t K) {
  double s = 0;
  for (size_t g = 0; g < G; ++g)
    for (size_t r = 0; r < R; ++r)
      for (size_t k = 0; k < K; ++k) {
        const double d = pred[(g * R + r) * K + k] - double(target[r * K + k]);
        s += mask[g * R + r] * d * d;
      }
  return s / double(G * R * K);
}

inline double ref_blending(const std::vector<float>& raw, size_t N, size_t M) {
  double s = 0;
  for (size_t m = 0; m < M; ++m) {
    double b = 0;
    for (size_t n = 0; n < N; ++n) b += loss_sigmoid(raw[(n * M + m) * 5 + 4]);
    s += std::fabs(b - 1);
  }
  return s / double(M);
}

inline double ref_alpha(const std::vector<float>& raw, const std::vector<float>& delta,
                 const std::vector<float>& masks, size_t N, size_t R, size_t S) {
  double s = 0;
  for (size_t n = 1; n < N; ++n)
    for (size_t r = 0; r < R; ++r)
      for (size_t i = 0; i < S; ++i) {
        const size_t at = (n * R + r) * S + i;
        const double sigma = std::max(0.0, double(raw[at * 5 + 3]));
        const double alpha = 1 - std::exp(-sigma * delta[r * S + i]);
        s += (1 - masks[n * R + r]) * (alpha + loss_sigmoid(raw[at * 5 + 4]));
      }
  return s / double((N - 1) * R * S);
}

// depth_loss (losses.hpp) on depths d, targets t and valid flags w: the mean squared
// difference of the standardised valid depths and targets; 0 with fewer than two valid rays.
inline double ref_depth_loss(const std::vector<double>& d, const std::vector<float>& t, const std::vector<float>& w) {
  const size_t R = d.size();
  double n = 0, sp = 0, st = 0;
  for (size_t r = 0; r < R; ++r) n += w[r], sp += w[r] * d[r], st += w[r] * t[r];
  if (n < 2) return 0;
  const double mp = sp / n, mt = st / n;
  double vp = 0, vt = 0;
  for (size_t r = 0; r < R; ++r) vp += w[r] * (d[r] - mp) * (d[r] - mp), vt += w[r] * (t[r] - mt) * (t[r] - mt);
  const double sdp = std::sqrt(vp / n + 1e-6), sdt = std::sqrt(vt / n + 1e-6);
  double sum = 0;
  for (size_t r = 0; r < R; ++r) {
    const double e = (d[r] - mp) / sdp - (t[r] - mt) / sdt;
    sum += w[r] * e * e;
  }
  return sum / n;
}

// Central differences of ref_depth_loss in each depth (h = 1e-6: exact to ~1e-9 for losses
// of order 1).
inline std::vector<double> ref_depth_loss_gradient(std::vector<double> d, const std::vector<float>& t,
                                                   const std::vector<float>& w) {
  std::vector<double> g(d.size());
  for (size_t r = 0; r < d.size(); ++r) {
    const double x0 = d[r], h = 1e-6;
    d[r] = x0 + h;
    const double lp = ref_depth_loss(d, t, w);
    d[r] = x0 - h;
    const double lm = ref_depth_loss(d, t, w);
    d[r] = x0;
    g[r] = (lp - lm) / (2 * h);
  }
  return g;
}

}  // namespace nova::test

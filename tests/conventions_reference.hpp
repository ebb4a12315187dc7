#pragma once
// Float64 references of the reference code's loss terms (LossConventions in novel_view_loss.hpp),
// written from the public reference code's losses.py, and their derivatives.
#include <algorithm>
#include <cmath>
#include <vector>

namespace nova::test {

// ---- float64 references, from the reference code's losses.py --------------------------
// mask_loss: img2mae(M_n, m_n) per NeRF (a mean over rays), summed over NeRFs.
inline double ref_mask_l1(const std::vector<float>& M, const std::vector<float>& m, size_t N, size_t R) {
  double s = 0;
  for (size_t n = 0; n < N; ++n) {
    double e = 0;
    for (size_t r = 0; r < R; ++r) e += std::fabs(double(M[n * R + r]) - m[n * R + r]);
    s += e / double(R);
  }
  return s;
}

// loss_RGB: img2mse(pred_n, target_n, mask_n[:, None]) = sum m (p - t)^2 / (sum m + 1e-8) / 3
// per NeRF, summed. target [G, R, K] (own) or [R, K] (shared).
inline double ref_mse_area(const std::vector<float>& p, const std::vector<float>& t, const std::vector<float>& m,
                    size_t G, size_t R, size_t K) {
  const bool own = t.size() == G * R * K;
  double s = 0;
  for (size_t g = 0; g < G; ++g) {
    double num = 0, den = 0;
    for (size_t r = 0; r < R; ++r) {
      den += m[g * R + r];
      for (size_t k = 0; k < K; ++k) {
        const double d = double(p[(g * R + r) * K + k]) - t[(own ? g * R * K : 0) + r * K + k];
        num += m[g * R + r] * d * d;
      }
    }
    s += num / (den + 1e-8) / double(K);
  }
  return s;
}

// mask_loss's object part: L1(blend_n[(1 - m_n).bool()]) + L1(alpha_n[(1 - m_n).bool()]) per
// object n >= 1 (means over the samples of the rays where m_n != 1), summed. An object with
// no such ray adds 0 here (the reference would take the mean of nothing).
inline double ref_alpha_outside(const std::vector<float>& raw, const std::vector<float>& delta,
                         const std::vector<float>& masks, const std::vector<float>& noise, size_t N,
                         size_t R, size_t S) {
  const bool per_nerf = delta.size() == N * R * S;
  double s = 0;
  for (size_t n = 1; n < N; ++n) {
    double sum_a = 0, sum_b = 0, count = 0;
    for (size_t r = 0; r < R; ++r) {
      if (masks[n * R + r] == 1.0f) continue;
      count += S;
      for (size_t i = 0; i < S; ++i) {
        const size_t e = (n * R + r) * S + i;
        const double sigma = std::max(0.0, double(raw[e * 5 + 3]) + (noise.empty() ? 0.0 : noise[e]));
        sum_a += 1.0 - std::exp(-sigma * delta[per_nerf ? e : r * S + i]);
        sum_b += 1.0 / (1.0 + std::exp(-double(raw[e * 5 + 4])));
      }
    }
    if (count > 0) s += sum_b / count + sum_a / count;
  }
  return s;
}

// order_loss: img2mae(depth[1:], depth[0:1], mask[0]) =
// sum_{k, r} m0 |d_k - d_0| / (sum m0 + 1e-8) / x.shape[-1], x = depth[1:] of shape [K, R].
inline double ref_order(const std::vector<float>& d, const std::vector<float>& m, size_t N, size_t R) {
  double num = 0, den = 0;
  for (size_t r = 0; r < R; ++r) {
    den += m[r];
    for (size_t n = 1; n < N; ++n) num += m[r] * std::fabs(double(d[n * R + r]) - d[r]);
  }
  return num / (den + 1e-8) / double(R);
}

// d ref_order / d depth.
inline std::vector<double> ref_order_grad(const std::vector<float>& d, const std::vector<float>& m, size_t N,
                                          size_t R) {
  double den = 0;
  for (size_t r = 0; r < R; ++r) den += m[r];
  const double f = 1.0 / ((den + 1e-8) * double(R));
  std::vector<double> g(N * R, 0.0);
  for (size_t r = 0; r < R; ++r)
    for (size_t n = 1; n < N; ++n) {
      const double diff = double(d[n * R + r]) - d[r];
      const double s = diff > 0 ? 1.0 : diff < 0 ? -1.0 : 0.0;
      g[n * R + r] += f * m[r] * s;
      g[r] -= f * m[r] * s;
    }
  return g;
}

// d ref_mse_area / d pred.
inline std::vector<double> ref_mse_area_grad(const std::vector<float>& p, const std::vector<float>& t,
                                             const std::vector<float>& m, size_t G, size_t R, size_t K) {
  const bool own = t.size() == G * R * K;
  std::vector<double> g(p.size(), 0.0);
  for (size_t gi = 0; gi < G; ++gi) {
    double den = 0;
    for (size_t r = 0; r < R; ++r) den += m[gi * R + r];
    for (size_t r = 0; r < R; ++r)
      for (size_t k = 0; k < K; ++k) {
        const size_t e = (gi * R + r) * K + k;
        g[e] = 2.0 * m[gi * R + r] * (double(p[e]) - t[(own ? gi * R * K : 0) + r * K + k]) / (den + 1e-8) / double(K);
      }
  }
  return g;
}

// d ref_alpha_outside / d raw (raw [N, R*S, 5], delta shared [R, S], no noise).
inline std::vector<double> ref_alpha_outside_grad(const std::vector<float>& raw, const std::vector<float>& delta,
                                                  const std::vector<float>& masks, size_t N, size_t R, size_t S) {
  std::vector<double> g(raw.size(), 0.0);
  for (size_t n = 1; n < N; ++n) {
    double count = 0;
    for (size_t r = 0; r < R; ++r) count += masks[n * R + r] != 1.0f ? double(S) : 0.0;
    if (count == 0) continue;
    for (size_t r = 0; r < R; ++r) {
      if (masks[n * R + r] == 1.0f) continue;
      for (size_t i = 0; i < S; ++i) {
        const size_t e = (n * R + r) * S + i;
        const double sigma = raw[e * 5 + 3], d = delta[r * S + i];
        const double b = 1.0 / (1.0 + std::exp(-double(raw[e * 5 + 4])));
        g[e * 5 + 3] = sigma > 0 ? d * std::exp(-sigma * d) / count : 0.0;
        g[e * 5 + 4] = b * (1 - b) / count;
      }
    }
  }
  return g;
}

}  // namespace nova::test

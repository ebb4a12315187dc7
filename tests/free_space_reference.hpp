#pragma once
// Float64 reference of the free-space loss (include/nova/losses.hpp, kernels/depth_loss.cl).
#include <algorithm>
#include <cmath>
#include <vector>

namespace nova::test {

struct FreeSpaceCase {
  size_t N = 0, R = 0, S = 0, C = 5, first = 1;
  float margin = 0.05f;
  std::vector<float> raw, delta, z, depth, target, valid, masks, noise;  // noise may be empty
  bool per_nerf_delta = true;
};

inline double free_space_reference(const FreeSpaceCase& f, const std::vector<float>& raw) {
  // Least-squares fit depth ~ a + b target over the valid background rays (masks row 0).
  double n = 0, sp = 0, st = 0;
  for (size_t r = 0; r < f.R; ++r) {
    const double w = f.valid[r] * f.masks[r];
    n += w, sp += w * f.depth[r], st += w * f.target[r];
  }
  if (n < 2) return 0;
  const double mp = sp / n, mt = st / n;
  double cov = 0, vt = 0;
  for (size_t r = 0; r < f.R; ++r) {
    const double w = f.valid[r] * f.masks[r];
    cov += w * (f.depth[r] - mp) * (f.target[r] - mt), vt += w * (f.target[r] - mt) * (f.target[r] - mt);
  }
  const double b = cov / (vt + 1e-6 * n), a = mp - b * mt;
  double sum = 0;
  for (size_t k = f.first; k < f.N; ++k)
    for (size_t r = 0; r < f.R; ++r) {
      const double m = f.valid[r] * f.masks[k * f.R + r];
      if (m == 0) continue;
      const double zt = a + b * f.target[r] - f.margin;
      double T = 1, L = 0;
      for (size_t i = 0; i < f.S; ++i) {
        const size_t e = (k * f.R + r) * f.S + i;
        const double s = raw[e * f.C + 3] + (f.noise.empty() ? 0.0 : f.noise[e]);
        const double d = f.delta[(f.per_nerf_delta ? k * f.R * f.S : 0) + r * f.S + i];
        const double a = 1 - std::exp(-std::max(s, 0.0) * d);
        L += T * a * std::max(zt - f.z[r * f.S + i], 0.0);
        T *= 1 - a;
      }
      sum += m * L;
    }
  return sum / double((f.N - f.first) * f.R);
}

}  // namespace nova::test

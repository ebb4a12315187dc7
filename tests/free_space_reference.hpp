#pragma once
// Float64 reference of the free-space loss (include/nova/loss/terms.hpp, kernels/free_space_loss.cl),
// its central differences, and one device run of the op on the same case.
#include <algorithm>
#include <cmath>
#include <vector>

#include "harness.hpp"
#include "nova/graph/executor.hpp"
#include "nova/loss/terms.hpp"

namespace nova::test {

struct FreeSpaceCase {
  size_t N = 0, R = 0, S = 0, C = 5, first = 1;
  float margin = 0.05f, behind = 0.0f;
  std::vector<float> raw, delta, z, depth, target, valid, masks, noise;  // noise may be empty
  bool per_nerf_delta = true;
  bool fitted = true;  // false: target is the surface itself (z* = target)
};

// The op table's case (op_table_ray_losses.cpp, op_table_ranks.cpp): N NeRFs x R rays x S
// samples with sigma in [0.3, 3.3], every fifth ray invalid, 30% of the masks 0, weight behind
// the surface too (behind 0.5).
inline FreeSpaceCase free_space_table_case(size_t N, size_t R, size_t S) {
  FreeSpaceCase f;
  f.N = N, f.R = R, f.S = S;
  f.raw = random_floats(f.N * R * f.S * f.C, -1, 1, 183);
  for (size_t e = 0; e < f.N * R * f.S; ++e) f.raw[e * f.C + 3] = 0.3f + std::fabs(f.raw[e * f.C + 3]) * 3;
  f.delta = random_floats(f.N * R * f.S, 0.1f, 0.4f, 184);
  for (size_t r = 0; r < R; ++r)
    for (size_t i = 0; i < f.S; ++i) f.z.push_back(0.2f + 0.3f * i);
  f.depth = random_floats(R, 0.0f, 1.0f, 181);
  f.target = random_floats(R, -2.0f, 3.0f, 182);
  f.valid.assign(R, 1.0f);
  for (size_t i = 0; i < R; i += 5) f.valid[i] = 0.0f;
  f.masks = random_floats(f.N * R, 0, 1, 185);
  for (float& m : f.masks) m = m < 0.3f ? 0.0f : 1.0f;
  f.behind = 0.5f;  // both sides of the surface
  return f;
}

// The op's own cases (test_free_space_loss_op.cpp, and the op table's shapes of the same size):
// sigma in [0.3, 4] (kept 0.3 from the ReLU kink), a delta per NeRF, every sixth ray invalid,
// 60% of the masks 1; `noise` adds density noise in [-0.1, 0.1].
inline FreeSpaceCase free_space_random_case(size_t N, size_t R, size_t S, bool noise, unsigned seed) {
  FreeSpaceCase f;
  f.N = N, f.R = R, f.S = S;
  f.raw = random_floats(N * R * S * f.C, -1, 1, seed);
  const auto sig = random_floats(N * R * S, 0.3f, 4.0f, seed + 1);
  for (size_t e = 0; e < N * R * S; ++e) f.raw[e * f.C + 3] = sig[e];
  f.delta = random_floats(N * R * S, 0.02f, 0.2f, seed + 2);
  for (size_t r = 0; r < R; ++r)
    for (size_t i = 0; i < S; ++i) f.z.push_back((i + 0.5f) / S);
  f.depth = random_floats(R, 0.2f, 0.9f, seed + 3);
  f.target = random_floats(R, -3.0f, -0.5f, seed + 4);
  f.valid.assign(R, 1.0f);
  for (size_t r = 0; r < R; r += 6) f.valid[r] = 0.0f;
  f.masks = random_floats(N * R, 0, 1, seed + 5);
  for (float& m : f.masks) m = m < 0.4f ? 0.0f : 1.0f;
  if (noise) {
    f.noise = random_floats(N * R * S, -0.1f, 0.1f, seed + 6);
  }
  return f;
}

inline double free_space_reference(const FreeSpaceCase& f, const std::vector<float>& raw) {
  // Least-squares fit depth ~ a + b target over the valid background rays (masks row 0).
  double n = 0, sp = 0, st = 0;
  for (size_t r = 0; r < f.R; ++r) {
    const double w = f.valid[r] * f.masks[r];
    n += w, sp += w * f.depth[r], st += w * f.target[r];
  }
  if (f.fitted && n < 2) return 0;
  const double mp = sp / n, mt = st / n;
  double cov = 0, vt = 0;
  for (size_t r = 0; r < f.R && f.fitted; ++r) {
    const double w = f.valid[r] * f.masks[r];
    cov += w * (f.depth[r] - mp) * (f.target[r] - mt), vt += w * (f.target[r] - mt) * (f.target[r] - mt);
  }
  const double b = f.fitted ? cov / (vt + 1e-6 * n) : 1.0, a = f.fitted ? mp - b * mt : 0.0;
  double sum = 0;
  for (size_t k = f.first; k < f.N; ++k)
    for (size_t r = 0; r < f.R; ++r) {
      const double m = f.valid[r] * f.masks[k * f.R + r];
      if (m == 0) continue;
      const double zs = a + b * f.target[r];
      double T = 1, L = 0;
      for (size_t i = 0; i < f.S; ++i) {
        const size_t e = (k * f.R + r) * f.S + i;
        const double s = raw[e * f.C + 3] + (f.noise.empty() ? 0.0 : f.noise[e]);
        const double d = f.delta[(f.per_nerf_delta ? k * f.R * f.S : 0) + r * f.S + i];
        const double a = 1 - std::exp(-std::max(s, 0.0) * d);
        const double zi = f.z[r * f.S + i];
        L += T * a * (std::max(zs - f.margin - zi, 0.0) + f.behind * std::max(zi - zs - f.margin, 0.0));
        T *= 1 - a;
      }
      sum += m * L;
    }
  return sum / double((f.N - f.first) * f.R);
}

// d loss / d raw by central differences of the reference in the sigma channel (0 elsewhere).
inline std::vector<double> free_space_sigma_fd(const FreeSpaceCase& f, float h) {
  std::vector<double> fd(f.raw.size(), 0.0);
  std::vector<float> x = f.raw;
  for (size_t e = 0; e < f.N * f.R * f.S; ++e) {
    const size_t i = e * f.C + 3;
    const float x0 = x[i];
    x[i] = x0 + h;
    const double lp = free_space_reference(f, x);
    x[i] = x0 - h;
    const double lm = free_space_reference(f, x);
    x[i] = x0;
    fd[i] = (lp - lm) / (double(x0 + h) - double(x0 - h));
  }
  return fd;
}

struct FreeSpaceRun {
  float loss;
  std::vector<float> d_raw, d_depth;
};

// One forward and backward of free_space_loss on the case. With `depth_also_in_mse` the depth
// also feeds an mse built before the op, so the op is the first writer of the depth's
// gradient in backward order and must clear it. With `ranks`, the case is this rank's rays of
// a batch split over ranks (the fit is the whole batch's).
inline FreeSpaceRun run_free_space(const FreeSpaceCase& f, Runtime& rt, bool depth_also_in_mse = false,
                                   GradientReducer* ranks = nullptr) {
  Graph g;
  const size_t N = f.N, R = f.R, S = f.S;
  Tensor raw = g.input("raw", Shape{N, R * S, f.C}, true);
  Tensor delta = g.input("delta", f.per_nerf_delta ? Shape{N, R, S} : Shape{R, S});
  Tensor z = g.input("z", Shape{R, S});
  Tensor depth = g.input("depth", Shape{R}, depth_also_in_mse);
  Tensor target = g.input("target", Shape{R}), valid = g.input("valid", Shape{R});
  Tensor masks = g.input("masks", Shape{N, R});
  Tensor noise = f.noise.empty() ? Tensor{} : g.input("noise", Shape{N, R * S});
  Tensor zero = g.input("zero", Shape{R});
  Tensor depth_mse = depth_also_in_mse ? mse(depth, zero) : Tensor{};
  Tensor fs = free_space_loss(raw, delta, z, depth, target, valid, masks, noise, f.margin, f.first,
                              f.behind, ranks, f.fitted);
  g.keep(fs);
  g.set_loss(depth_also_in_mse ? weighted_sum({depth_mse, fs}, {1.0f, 1.0f}) : fs);
  Executor ex(rt, g, guarded_options());
  ex.set(raw, f.raw);
  ex.set(delta, f.delta);
  ex.set(z, f.z);
  ex.set(depth, f.depth);
  ex.set(target, f.target);
  ex.set(valid, f.valid);
  ex.set(masks, f.masks);
  if (noise.valid()) ex.set(noise, f.noise);
  ex.set(zero, std::vector<float>(R, 0.0f));
  ex.forward();
  ex.backward();
  return {ex.get(fs).at(0), ex.get_grad(raw),
          depth_also_in_mse ? ex.get_grad(depth) : std::vector<float>{}};
}

}  // namespace nova::test

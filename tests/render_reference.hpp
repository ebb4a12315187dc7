#pragma once
// Float64 host reference of the compositing renderer, written straight from the formulas
// (as include/nova/render/render_composite.hpp states them) and independent of kernels/render.cl: no union-of-probabilities
// trick, no reverse scan; gradients come from central differences of this function.
#include <algorithm>
#include <cmath>
#include <vector>

#include "harness.hpp"
#include "nova/render/render_composite.hpp"

namespace nova::test {

struct RenderRefInput {
  int nerfs = 1, rays = 1, samples = 1, channels = 5;
  std::vector<double> raw;    // [N, R, S, C]
  std::vector<double> delta;  // [R, S] or [N, R, S]
  std::vector<double> z;      // [R, S]
  std::vector<double> noise;  // empty or [N, R, S]
  bool rgb_sigmoid = true, blend_sigmoid = true, hard_blend = false;
  // The reference code's conventions (RenderOptions): blend epsilon, alpha_full as the sum
  // of alpha_n b_n, no blending at all (b_n = 1), and the per-NeRF depth output.
  double blend_eps = 1e-6;
  bool alpha_full_sum = false, no_blend = false, nerf_depth = false;
};

struct RenderRefOutput {
  std::vector<double> rgb, nerf_rgb, mask, depth, acc, nerf_depth;
};

inline double ref_sigmoid(double x) { return 1.0 / (1.0 + std::exp(-x)); }

inline RenderRefOutput render_reference(const RenderRefInput& in) {
  const int N = in.nerfs, R = in.rays, S = in.samples, C = in.channels;
  const bool per_nerf_delta = in.delta.size() == static_cast<size_t>(N) * R * S;
  RenderRefOutput out;
  out.rgb.assign(R * 3, 0.0);
  out.nerf_rgb.assign(N * R * 3, 0.0);
  out.mask.assign(N * R, 0.0);
  out.depth.assign(R, 0.0);
  out.acc.assign(R, 0.0);
  out.nerf_depth.assign(N * R, 0.0);
  std::vector<double> Tn(N), alpha(N), blend(N), c(N * 3);
  for (int r = 0; r < R; ++r) {
    double T = 1.0;
    std::fill(Tn.begin(), Tn.end(), 1.0);
    for (int i = 0; i < S; ++i) {
      for (int n = 0; n < N; ++n) {
        const size_t at = (static_cast<size_t>(n) * R + r) * S + i;
        const double* p = &in.raw[at * C];
        const double sigma = std::max(0.0, p[3] + (in.noise.empty() ? 0.0 : in.noise[at]));
        const double d = in.delta[per_nerf_delta ? at : static_cast<size_t>(r) * S + i];
        alpha[n] = 1.0 - std::exp(-sigma * d);
        blend[n] = in.no_blend ? 1.0 : in.blend_sigmoid ? ref_sigmoid(p[4]) : p[4];
        for (int k = 0; k < 3; ++k) c[n * 3 + k] = in.rgb_sigmoid ? ref_sigmoid(p[k]) : p[k];
      }
      if (in.hard_blend) {
        bool object = false;
        for (int n = 1; n < N; ++n) object = object || blend[n] > 0.5;
        if (object) blend[0] = 0.0;
      }
      double bsum = 0;
      for (double b : blend) bsum += b;
      const auto normalised = [&](int n) { return in.no_blend ? 1.0 : blend[n] / (bsum + in.blend_eps); };
      double keep = 1.0;  // prod_n (1 - alpha_n b_n)
      double sum_ab = 0.0;
      for (int n = 0; n < N; ++n) {
        const double b = normalised(n);
        keep *= 1.0 - alpha[n] * b;
        sum_ab += alpha[n] * b;
        out.nerf_depth[n * R + r] += Tn[n] * alpha[n] * in.z[r * S + i];
        for (int k = 0; k < 3; ++k) out.rgb[r * 3 + k] += T * alpha[n] * b * c[n * 3 + k];
        for (int k = 0; k < 3; ++k)
          out.nerf_rgb[(n * R + r) * 3 + k] += Tn[n] * alpha[n] * c[n * 3 + k];
        Tn[n] *= 1.0 - alpha[n] + 1e-10;
      }
      const double alpha_full = in.alpha_full_sum ? sum_ab : 1.0 - keep;
      for (int n = 0; n < N; ++n) out.mask[n * R + r] += T * alpha_full * normalised(n);
      out.depth[r] += T * alpha_full * in.z[r * S + i];
      out.acc[r] += T * alpha_full;
      T *= keep + 1e-10;
    }
  }
  return out;
}

// The device's options for the reference's conventions.
inline RenderOptions render_options(const RenderRefInput& in) {
  RenderOptions o;
  o.rgb_sigmoid = in.rgb_sigmoid;
  o.blend_sigmoid = in.blend_sigmoid;
  o.hard_blend = in.hard_blend;
  o.blend_eps = static_cast<float>(in.blend_eps);
  o.alpha_full_sum = in.alpha_full_sum;
  o.no_blend = in.no_blend;
  o.nerf_depth = in.nerf_depth;
  return o;
}

inline std::vector<float> to_float(const std::vector<double>& v) { return {v.begin(), v.end()}; }

// Moderate random fields: raw rgb and blend in [-3, 3], sigma in [-1, 4] (a quarter of the
// samples clipped by the ReLU), spacing like 64 NDC samples (1/64 * |d|, |d| in [0.8, 1.2]),
// the last sample 1e10 |d| as the reference does.
inline RenderRefInput random_render_case(int nerfs, int rays, int samples, int channels, bool per_nerf_delta,
                           bool noise, unsigned seed) {
  RenderRefInput in;
  in.nerfs = nerfs;
  in.rays = rays;
  in.samples = samples;
  in.channels = channels;
  const size_t rs = static_cast<size_t>(rays) * samples;
  in.raw = to_double(random_floats(nerfs * rs * channels, -3, 3, seed));
  const auto sig = random_floats(nerfs * rs, -1, 4, seed + 1);
  for (size_t s = 0; s < nerfs * rs; ++s) in.raw[s * channels + 3] = sig[s];
  const size_t dn = per_nerf_delta ? nerfs : 1;
  const auto norm = random_floats(dn * rays, 0.8f, 1.2f, seed + 2);
  in.delta.resize(dn * rs);
  for (size_t q = 0; q < dn * static_cast<size_t>(rays); ++q)
    for (int i = 0; i < samples; ++i)
      in.delta[q * samples + i] = static_cast<float>((i + 1 < samples ? 1.0 / samples : 1e10) * norm[q]);
  in.z.resize(rs);
  for (int r = 0; r < rays; ++r)
    for (int i = 0; i < samples; ++i) in.z[r * samples + i] = static_cast<float>((i + 0.5) / samples);
  if (noise) in.noise = to_double(random_floats(nerfs * rs, -1, 1, seed + 3));
  return in;
}

}  // namespace nova::test

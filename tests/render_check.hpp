#pragma once
// Shared checks of render_composite against the float64 reference (render_reference.hpp):
// the device forward, and the device gradient against central differences of the float64
// reference under the same loss, L = sum over the five outputs of mse(output, target).
#include <boost/test/unit_test.hpp>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "harness.hpp"
#include "nova/loss/terms.hpp"
#include "nova/render/render_composite.hpp"
#include "render_reference.hpp"

namespace nova::test {

struct RenderTargets {
  std::vector<double> rgb, nerf_rgb, mask, depth, acc;
  std::vector<double> nerf_depth;  // used only when the input asks for nerf_depth
};

inline RenderTargets random_targets(const RenderRefInput& in, unsigned seed) {
  const size_t N = in.nerfs, R = in.rays;
  RenderTargets t;
  t.rgb = to_double(random_floats(R * 3, 0, 1, seed));
  t.nerf_rgb = to_double(random_floats(N * R * 3, 0, 1, seed + 1));
  t.mask = to_double(random_floats(N * R, 0, 1, seed + 2));
  double zmax = 0;
  for (double z : in.z) zmax = std::max(zmax, z);
  t.depth = to_double(random_floats(R, 0, static_cast<float>(zmax), seed + 3));
  t.acc = to_double(random_floats(R, 0, 1, seed + 4));
  if (in.nerf_depth) t.nerf_depth = to_double(random_floats(N * R, 0, static_cast<float>(zmax), seed + 5));
  return t;
}

inline double mean_sq(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i) s += (a[i] - b[i]) * (a[i] - b[i]);
  return s / static_cast<double>(a.size());
}

inline double reference_loss(const RenderRefInput& in, const RenderTargets& t) {
  const RenderRefOutput o = render_reference(in);
  return mean_sq(o.rgb, t.rgb) + mean_sq(o.nerf_rgb, t.nerf_rgb) + mean_sq(o.mask, t.mask) +
         mean_sq(o.depth, t.depth) + mean_sq(o.acc, t.acc) +
         (in.nerf_depth ? mean_sq(o.nerf_depth, t.nerf_depth) : 0.0);
}

// The part of reference_loss that depends on ray r (rays are independent), with the
// normalisation of the whole loss: finite differences then cost one ray, not all of them.
struct RayProblem {
  RenderRefInput in;
  RenderTargets t;
  double weights[6];  // 1 / element count of each whole output
};

inline RayProblem ray_problem(const RenderRefInput& in, const RenderTargets& t, int r) {
  const size_t N = in.nerfs, R = in.rays, S = in.samples, C = in.channels;
  RayProblem p;
  p.in = in;
  p.in.rays = 1;
  p.in.raw.clear();
  p.in.delta.clear();
  p.in.noise.clear();
  const bool per_nerf = in.delta.size() == N * R * S;
  for (size_t n = 0; n < N; ++n) {
    const size_t at = (n * R + r) * S;
    p.in.raw.insert(p.in.raw.end(), in.raw.begin() + at * C, in.raw.begin() + (at + S) * C);
    if (!in.noise.empty())
      p.in.noise.insert(p.in.noise.end(), in.noise.begin() + at, in.noise.begin() + at + S);
    if (per_nerf || n == 0) {
      const size_t d = per_nerf ? at : r * S;
      p.in.delta.insert(p.in.delta.end(), in.delta.begin() + d, in.delta.begin() + d + S);
    }
  }
  p.in.z.assign(in.z.begin() + r * S, in.z.begin() + (r + 1) * S);
  p.t.rgb.assign(t.rgb.begin() + r * 3, t.rgb.begin() + r * 3 + 3);
  for (size_t n = 0; n < N; ++n) {
    p.t.nerf_rgb.insert(p.t.nerf_rgb.end(), t.nerf_rgb.begin() + (n * R + r) * 3,
                        t.nerf_rgb.begin() + (n * R + r) * 3 + 3);
    p.t.mask.push_back(t.mask[n * R + r]);
    if (in.nerf_depth) p.t.nerf_depth.push_back(t.nerf_depth[n * R + r]);
  }
  p.t.depth = {t.depth[r]};
  p.t.acc = {t.acc[r]};
  const double sizes[6] = {3.0 * R, 3.0 * N * R, 1.0 * N * R, 1.0 * R, 1.0 * R, 1.0 * N * R};
  for (int k = 0; k < 6; ++k) p.weights[k] = 1.0 / sizes[k];
  return p;
}

inline double ray_loss(const RayProblem& p) {
  const RenderRefOutput o = render_reference(p.in);
  const auto sq = [](const std::vector<double>& a, const std::vector<double>& b) {
    double s = 0;
    for (size_t i = 0; i < a.size(); ++i) s += (a[i] - b[i]) * (a[i] - b[i]);
    return s;
  };
  return p.weights[0] * sq(o.rgb, p.t.rgb) + p.weights[1] * sq(o.nerf_rgb, p.t.nerf_rgb) +
         p.weights[2] * sq(o.mask, p.t.mask) + p.weights[3] * sq(o.depth, p.t.depth) +
         p.weights[4] * sq(o.acc, p.t.acc) +
         (p.in.nerf_depth ? p.weights[5] * sq(o.nerf_depth, p.t.nerf_depth) : 0.0);
}

struct DeviceRender {
  std::vector<float> rgb, nerf_rgb, mask, depth, acc, grad_raw;
  std::vector<float> nerf_depth;  // only when the input asks for it
};

// Builds render_composite + the five-term loss on the device, runs forward and backward.
inline DeviceRender run_device_render(const RenderRefInput& in, const RenderTargets& t,
                                      bool check_finite = false) {
  const size_t N = in.nerfs, R = in.rays, S = in.samples, C = in.channels;
  Graph g;
  Tensor raw = g.input("raw", Shape{N, R * S, C}, true);
  Tensor delta = in.delta.size() == R * S ? g.input("delta", Shape{R, S})
                                          : g.input("delta", Shape{N, R, S});
  Tensor z = g.input("z", Shape{R, S});
  Tensor noise = in.noise.empty() ? Tensor{} : g.input("noise", Shape{N, R * S});
  RenderOutputs out = render_composite(raw, delta, z, noise, render_options(in));
  std::vector<Tensor> outs = {out.rgb, out.nerf_rgb, out.mask, out.depth, out.acc};
  std::vector<const std::vector<double>*> targets = {&t.rgb, &t.nerf_rgb, &t.mask, &t.depth, &t.acc};
  if (in.nerf_depth) {
    outs.push_back(out.nerf_depth);
    targets.push_back(&t.nerf_depth);
  }
  std::vector<Tensor> terms, target_tensors;
  for (const Tensor& x : outs) {
    g.keep(x);
    target_tensors.push_back(g.input(x.info().name + ".target", x.shape()));
    terms.push_back(mse(x, target_tensors.back()));
  }
  g.set_loss(weighted_sum(terms, std::vector<float>(terms.size(), 1.0f)));
  ExecutorOptions eo = guarded_options();
  eo.check_finite = check_finite;
  Executor ex(runtime(), g, eo);
  ex.set(raw, to_float(in.raw));
  ex.set(delta, to_float(in.delta));
  ex.set(z, to_float(in.z));
  if (noise.valid()) ex.set(noise, to_float(in.noise));
  for (size_t k = 0; k < outs.size(); ++k) ex.set(target_tensors[k], to_float(*targets[k]));
  ex.forward();
  ex.backward();
  DeviceRender d;
  d.rgb = ex.get(out.rgb);
  d.nerf_rgb = ex.get(out.nerf_rgb);
  d.mask = ex.get(out.mask);
  d.depth = ex.get(out.depth);
  d.acc = ex.get(out.acc);
  if (in.nerf_depth) d.nerf_depth = ex.get(out.nerf_depth);
  d.grad_raw = ex.get_grad(raw);
  return d;
}

inline bool all_finite(const std::vector<float>& v) {
  return std::all_of(v.begin(), v.end(), [](float x) { return std::isfinite(x); });
}

// Forward: every output of the device within atol * scale + rtol |expected| of the float64
// reference; `scale` is 1 for colours, masks and opacity (all in [0, 1 + S * 1e-10]) and the
// largest z for the depth.
inline void expect_forward_close(const DeviceRender& d, const RenderRefInput& in, double atol,
                                 double rtol, const std::string& what) {
  const RenderRefOutput o = render_reference(in);
  double zmax = 1e-30;
  for (double z : in.z) zmax = std::max(zmax, std::fabs(z));
  for (const auto* v : {&d.rgb, &d.nerf_rgb, &d.mask, &d.depth, &d.acc})
    BOOST_TEST(all_finite(*v), what << ": non-finite output");
  double worst = 0;
  for (auto [a, b] : {std::pair{&d.rgb, &o.rgb}, {&d.nerf_rgb, &o.nerf_rgb}, {&d.mask, &o.mask},
                      {&d.acc, &o.acc}})
    worst = std::max(worst, max_scaled_error(*a, *b, atol, rtol));
  worst = std::max(worst, max_scaled_error(d.depth, o.depth, atol * zmax, rtol));
  BOOST_TEST_MESSAGE(what << ": worst forward error " << worst << " of the tolerance");
  expect_close(d.rgb, o.rgb, atol, rtol, what + " rgb");
  expect_close(d.nerf_rgb, o.nerf_rgb, atol, rtol, what + " nerf_rgb");
  expect_close(d.mask, o.mask, atol, rtol, what + " mask");
  expect_close(d.depth, o.depth, atol * zmax, rtol, what + " depth");
  expect_close(d.acc, o.acc, atol, rtol, what + " acc");
  if (in.nerf_depth) expect_close(d.nerf_depth, o.nerf_depth, atol * zmax, rtol, what + " nerf_depth");
}

// Gradient: the device d loss / d raw against float64 central differences of
// reference_loss, for every element. Steps are relative (1e-6 |x|, at least 1e-9), and for a
// sigma no larger than 1e-4 / delta, so that sigma * delta moves by at most 1e-4 and the
// truncation error stays far below the tolerance. The error allowed for element e is
// rtol |fd| + atol * g * m_e, with g the largest |gradient| over the rgb and blend channels
// (the scale of the upstream gradients) and m_e = max(1, delta_e) for sigma entries, because
// d alpha / d sigma = delta exp(-sigma delta) multiplies every float32 rounding error there.
// sample_stride > 1 checks the first and last 16 samples and every sample_stride-th between
// (the float64 differences dominate the run time of long rays).
inline void expect_gradient_close(const DeviceRender& d, const RenderRefInput& in,
                                  const RenderTargets& t, double atol, double rtol,
                                  const std::string& what, size_t sample_stride = 1) {
  const size_t N = in.nerfs, R = in.rays, S = in.samples, C = in.channels;
  BOOST_TEST(all_finite(d.grad_raw), what << ": non-finite gradient");
  const bool per_nerf = in.delta.size() == N * R * S;
  std::vector<double> fd(in.raw.size(), 0.0), m(in.raw.size(), 1.0);
  std::vector<bool> checked(in.raw.size(), true);
  for (size_t r = 0; r < R; ++r) {
    RayProblem p = ray_problem(in, t, static_cast<int>(r));
    for (size_t n = 0; n < N; ++n)
      for (size_t local = n * S * C; local < (n + 1) * S * C; ++local) {
        const size_t i = (local / C) % S, sample = (n * R + r) * S + i, ch = local % C;
        const size_t e = sample * C + ch;
        if (ch >= 5) continue;  // ignored channels: the reference gradient is exactly 0
        if (i >= 16 && i + 16 < S && i % sample_stride) {
          checked[e] = false;
          continue;
        }
        const double x0 = p.in.raw[local];
        double h = std::max(1e-9, 1e-6 * std::fabs(x0));
        if (ch == 3) {
          const double dl = in.delta[per_nerf ? sample : sample % (R * S)];
          h = std::min(h, std::max(1e-4 / dl, 1e-300));
          m[e] = std::max(1.0, dl);
        }
        p.in.raw[local] = x0 + h;
        const double lp = ray_loss(p);
        p.in.raw[local] = x0 - h;
        const double lm = ray_loss(p);
        p.in.raw[local] = x0;
        fd[e] = (lp - lm) / (2 * h);
      }
  }
  double g = 1e-12;
  for (size_t e = 0; e < fd.size(); ++e)
    if (e % C != 3) g = std::max(g, std::fabs(fd[e]));
  size_t worst_e = 0;
  double worst = 0;
  for (size_t e = 0; e < fd.size(); ++e) {
    if (!checked[e]) continue;
    const double err = std::fabs(d.grad_raw[e] - fd[e]) / (rtol * std::fabs(fd[e]) + atol * g * m[e]);
    if (!(err <= worst)) {
      worst = std::isnan(err) ? INFINITY : err;
      worst_e = e;
    }
  }
  BOOST_TEST_MESSAGE(what << ": worst gradient error " << worst << " of the tolerance");
  BOOST_TEST(worst <= 1.0, what << ": d loss / d raw[" << worst_e << "] (channel "
                                << worst_e % C << ") is " << d.grad_raw[worst_e]
                                << ", float64 finite difference " << fd[worst_e]);
}

}  // namespace nova::test

// The renderer against closed-form volume rendering integrals of two analytic fields: a
// constant-density slab (static NeRF) behind a constant-density sphere (object NeRF), each
// with a known colour, the blend 1 inside its own object and 0 elsewhere.
#include <boost/test/unit_test.hpp>
#include <cmath>

#include "harness.hpp"
#include "nova/render/render_composite.hpp"

using namespace nova;
using namespace nova::test;

namespace {

constexpr double kSlabNear = 1.0, kSlabFar = 2.0, kSlabSigma = 1.5;
constexpr double kSphereCentre = 0.5, kSphereRadius = 0.4, kSphereSigma = 2.0;
constexpr double kFar = 4.0;
constexpr int kSamples = 4096;
constexpr double kStep = kFar / kSamples;  // 2^-10: exact in float, so are the slab bounds
const double kSlabRgb[3] = {0.9, 0.2, 0.1}, kSphereRgb[3] = {0.1, 0.3, 0.8};

// The exact integral along a ray passing at distance h from the sphere's centre (and
// crossing the whole slab): colour, opacity, per-NeRF masks and expected depth, from
// T(z) = exp(-int sigma), C = int T sigma c dz.
struct Exact {
  double rgb[3], acc, mask_static, mask_object, depth, static_alone[3], object_alone[3];
};

// int over [z0, z0 + L] of T0 sigma e^{-sigma (z - z0)} z dz.
double depth_integral(double T0, double sigma, double z0, double L) {
  const double e = std::exp(-sigma * L);
  return T0 * (z0 * (1 - e) + (1 - e) / sigma - L * e);
}

Exact exact(double h) {
  const double chord = h < kSphereRadius ? 2 * std::sqrt(kSphereRadius * kSphereRadius - h * h) : 0;
  const double sphere_t = std::exp(-kSphereSigma * chord), slab_t = std::exp(-kSlabSigma * (kSlabFar - kSlabNear));
  Exact x;
  x.mask_object = 1 - sphere_t;
  x.mask_static = sphere_t * (1 - slab_t);
  x.acc = x.mask_object + x.mask_static;
  for (int k = 0; k < 3; ++k) {
    x.rgb[k] = x.mask_object * kSphereRgb[k] + x.mask_static * kSlabRgb[k];
    x.static_alone[k] = (1 - slab_t) * kSlabRgb[k];
    x.object_alone[k] = (1 - sphere_t) * kSphereRgb[k];
  }
  x.depth = (chord > 0 ? depth_integral(1, kSphereSigma, kSphereCentre - chord / 2, chord) : 0) +
            depth_integral(sphere_t, kSlabSigma, kSlabNear, kSlabFar - kSlabNear);
  return x;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(render_analytic)

// Tolerances. The slab's bounds fall on samples, so its piecewise-constant quadrature is
// exact (products of exp(-sigma step) are exp(-sigma L)); what remains is float32 rounding
// over 4096 samples (~4096 * 6e-8 = 2.5e-4 relative in the transmittance product, in practice
// far less): atol 3e-4 for a slab-only ray. The sphere's chord does not fall on samples: its
// length is off by up to one step, so opacities are off by up to sigma * step = 2e-3 —
// atol 2.5e-3 for rays through the sphere. The expected depth is a left Riemann sum, off by up
// to one step (1e-3) plus the chord error times the depth range: atol 1e-2.
BOOST_AUTO_TEST_CASE(slab_and_sphere_match_closed_form) {
  const std::vector<double> offsets = {0.0, 0.1, 0.2, 0.3, 0.35, 0.39, 0.5, 0.8};
  const size_t R = offsets.size(), S = kSamples, N = 2;
  std::vector<float> raw(N * R * S * 5), delta(R * S), z(R * S);
  for (size_t r = 0; r < R; ++r) {
    const double h = offsets[r];
    for (size_t i = 0; i < S; ++i) {
      const double zi = i * kStep;
      z[r * S + i] = static_cast<float>(zi);
      delta[r * S + i] = static_cast<float>(i + 1 < S ? kStep : 1e10);
      const double dz = zi - kSphereCentre;
      const bool in_sphere = dz * dz + h * h < kSphereRadius * kSphereRadius;
      const bool in_slab = zi >= kSlabNear && zi < kSlabFar;
      float* st = &raw[(0 * R * S + r * S + i) * 5];
      float* ob = &raw[(1 * R * S + r * S + i) * 5];
      for (int k = 0; k < 3; ++k) {
        st[k] = static_cast<float>(kSlabRgb[k]);
        ob[k] = static_cast<float>(kSphereRgb[k]);
      }
      st[3] = in_slab ? static_cast<float>(kSlabSigma) : -1.0f;  // ReLU: 0 outside
      ob[3] = in_sphere ? static_cast<float>(kSphereSigma) : -1.0f;
      st[4] = in_sphere ? 0.0f : 1.0f;
      ob[4] = in_sphere ? 1.0f : 0.0f;
    }
  }
  Graph g;
  Tensor traw = g.input("raw", Shape{N, R * S, 5}), td = g.input("delta", Shape{R, S}),
         tz = g.input("z", Shape{R, S});
  RenderOptions o;
  o.rgb_sigmoid = o.blend_sigmoid = false;  // the fields give activated values
  RenderOutputs out = render_composite(traw, td, tz, Tensor{}, o);
  for (Tensor t : {out.rgb, out.nerf_rgb, out.mask, out.depth, out.acc}) g.keep(t);
  Executor ex(runtime(), g);
  ex.set(traw, raw);
  ex.set(td, delta);
  ex.set(tz, z);
  ex.forward();
  const auto rgb = ex.get(out.rgb), nerf_rgb = ex.get(out.nerf_rgb), mask = ex.get(out.mask),
             depth = ex.get(out.depth), acc = ex.get(out.acc);
  for (size_t r = 0; r < R; ++r) {
    const Exact x = exact(offsets[r]);
    const bool through_sphere = offsets[r] < kSphereRadius;
    const double atol = through_sphere ? 2.5e-3 : 3e-4;
    const std::string what = "ray at offset " + std::to_string(offsets[r]);
    expect_close({rgb.begin() + r * 3, rgb.begin() + r * 3 + 3}, {x.rgb, x.rgb + 3}, atol, 0, what + " rgb");
    expect_close({acc[r]}, {x.acc}, atol, 0, what + " acc");
    expect_close({mask[r], mask[R + r]}, {x.mask_static, x.mask_object}, atol, 0, what + " masks");
    expect_close({depth[r]}, {x.depth}, 1e-2, 0, what + " depth");
    expect_close({nerf_rgb.begin() + r * 3, nerf_rgb.begin() + r * 3 + 3},
                 {x.static_alone, x.static_alone + 3}, 3e-4, 0, what + " static NeRF alone");
    expect_close({nerf_rgb.begin() + (R + r) * 3, nerf_rgb.begin() + (R + r) * 3 + 3},
                 {x.object_alone, x.object_alone + 3}, atol, 0, what + " object NeRF alone");
  }
}

BOOST_AUTO_TEST_SUITE_END()

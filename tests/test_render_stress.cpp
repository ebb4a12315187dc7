// Numerical stress of render_composite: extreme densities and spacings, degenerate blends,
// opaque first samples, 256 samples and 8 NeRFs. Every output and gradient must be finite
// (the executor's check_finite mode checks every tensor after every op) and match the float64
// reference.
#include <boost/test/unit_test.hpp>
#include <cmath>

#include "harness.hpp"
#include "render_check.hpp"

using namespace nova;
using namespace nova::test;

namespace {

constexpr int kNerfs = 8, kSamples = 256;

// One ray (two for the cheaper cases) of 8 NeRFs x 256 samples; raw rgb and blend random in
// [-3, 3]. Sigma and spacing are filled by the case.
RenderRefInput base_case(int rays, unsigned seed) {
  RenderRefInput in;
  in.nerfs = kNerfs;
  in.rays = rays;
  in.samples = kSamples;
  in.channels = 5;
  const size_t rs = static_cast<size_t>(rays) * kSamples;
  in.raw = to_double(random_floats(kNerfs * rs * 5, -3, 3, seed));
  in.delta.assign(kNerfs * rs, 1.0 / kSamples);
  in.z.resize(rs);
  for (size_t e = 0; e < rs; ++e) in.z[e] = 2.0 + 4.0 * static_cast<double>(e % kSamples) / kSamples;
  return in;
}

double& sigma(RenderRefInput& in, size_t n, size_t r, size_t i) {
  return in.raw[((n * in.rays + r) * in.samples + i) * 5 + 3];
}
double& blend(RenderRefInput& in, size_t n, size_t r, size_t i) {
  return in.raw[((n * in.rays + r) * in.samples + i) * 5 + 4];
}
double& delta(RenderRefInput& in, size_t n, size_t r, size_t i) {
  return in.delta[(n * in.rays + r) * in.samples + i];
}

// A float32-representable value 10^e.
double pow10f(double e) { return static_cast<float>(std::pow(10.0, e)); }

// Forward: atol 1e-5, rtol 1e-4 (5x the moderate suite's): with 256 samples the transmittance
// is a product of 256 float32 factors (relative error up to 256 * 6e-8 = 1.5e-5), and at
// 8 NeRFs each sample sums 8 blended terms.
// Gradient: rtol 2e-3, atol 2e-4 of the gradient scale (times max(1, delta) on sigma entries;
// see render_check.hpp): the reverse-scan sums run over 256 samples with cancellation, about
// 256 * 1e-7 = 3e-5 relative to the scale, times a safety factor for the 8-way products.
void check_case(const RenderRefInput& in, const std::string& what) {
  const RenderTargets t = random_targets(in, 1234);
  // check_finite: the executor stops at the first non-finite tensor, naming op and tensor.
  const DeviceRender d = run_device_render(in, t, /*check_finite=*/true);
  expect_forward_close(d, in, 1e-5, 1e-4, what);
  expect_gradient_close(d, in, t, 2e-4, 2e-3, what, /*sample_stride=*/4);
}

}  // namespace

BOOST_AUTO_TEST_SUITE(render_stress)

// Sigma from 0 (a clipped negative raw value) to 1e8 and spacings from 1e-9 to 1e10 (the
// last sample), spread over the samples and NeRFs so that every product sigma * delta from
// 1e-9 to 1e18 occurs.
BOOST_AUTO_TEST_CASE(extreme_sigma_and_spacing) {
  RenderRefInput in = base_case(1, 21);
  const auto u = random_floats(kNerfs * kSamples * 2, 0, 1, 22);
  for (int n = 0; n < kNerfs; ++n)
    for (int i = 0; i < kSamples; ++i) {
      const float a = u[(n * kSamples + i) * 2], b = u[(n * kSamples + i) * 2 + 1];
      // Sigma 10^[-4, 8], or 0 for one sample in eight.
      sigma(in, n, 0, i) = a < 0.125f ? -1.0 : pow10f(-4 + 12 * (a - 0.125) / 0.875);
      delta(in, n, 0, i) = i + 1 == kSamples ? 1e10 : pow10f(-9 + 12 * b);
    }
  check_case(in, "extreme sigma and spacing");
}

BOOST_AUTO_TEST_CASE(all_blends_zero_and_all_one) {
  for (double value : {0.0, 1.0}) {
    RenderRefInput in = base_case(1, 31);
    in.blend_sigmoid = false;
    const auto u = random_floats(kNerfs * 2 * kSamples, 0, 1, 32);
    for (int n = 0; n < kNerfs; ++n)
      for (int i = 0; i < kSamples; ++i) {
        blend(in, n, 0, i) = value;
        sigma(in, n, 0, i) = pow10f(-2 + 4 * u[n * kSamples + i]);
        if (i + 1 == kSamples) delta(in, n, 0, i) = 1e10;
      }
    check_case(in, value == 0.0 ? "all blends 0" : "all blends 1");
  }
}

BOOST_AUTO_TEST_CASE(opaque_at_first_sample) {
  // Every NeRF opaque at sample 0 (sigma 1e8, alpha = 1): T drops to 1e-10 at once, and
  // on ray 1 to the float32 underflow range after a few samples.
  RenderRefInput in = base_case(2, 41);
  for (int n = 0; n < kNerfs; ++n)
    for (int r = 0; r < 2; ++r) {
      sigma(in, n, r, 0) = 1e8;
      if (r == 1)
        for (int i = 1; i < 6; ++i) sigma(in, n, r, i) = 1e8;
      delta(in, n, r, kSamples - 1) = 1e10;
    }
  check_case(in, "opaque first sample");
}

BOOST_AUTO_TEST_CASE(one_opaque_object_among_transparent_nerfs) {
  // NeRF 3 alone is opaque at sample 10 with its blend dominating; the others are empty
  // (sigma 0): the composite must become the object's colour and M_3 close to 1.
  RenderRefInput in = base_case(1, 51);
  for (int n = 0; n < kNerfs; ++n)
    for (int i = 0; i < kSamples; ++i) {
      sigma(in, n, 0, i) = n == 3 && i == 10 ? 1e8 : -0.5;
      blend(in, n, 0, i) = n == 3 ? 12.0 : -12.0;
      if (i + 1 == kSamples) delta(in, n, 0, i) = 1e10;
    }
  check_case(in, "one opaque object");
}

// The blend channel's gradient where one NeRF's normalised blend b_n is within the epsilon of
// 1: a NeRF alone (static pretraining, where blend matters only through b = blend / (blend +
// 1e-6)), and a NeRF whose blend dominates one other's (sigmoid(-12) = 6e-6). There the
// gradient is about 1e-6 of the colour channels', below the tolerance check_case scales to
// those; it is checked here on its own scale. An exact but cancelling formula, gb_n -
// sum_m gb_m b_m, leaves a few ulps of gb_n, errors of 1-10% of this gradient per sample,
// which Adam's normalisation turns into steps as large as those of any other weight.
// Reference: float64 central differences with h = 1e-3 in the raw blend (the dependence is
// smooth: truncation about h^2 / 6 = 2e-7 relative). Allowed: 1e-3 relative plus 1e-4 of the
// largest blend gradient (float32 rounding of the upstream terms, 16 samples).
BOOST_AUTO_TEST_CASE(blend_gradient_where_one_blend_is_nearly_one) {
  for (const int nerfs : {1, 2}) {
    RenderRefInput in = random_render_case(nerfs, 4, 16, 5, false, true, 61);
    if (nerfs == 2)
      for (size_t e = in.raw.size() / 2 + 4; e < in.raw.size(); e += 5) in.raw[e] = -12.0;  // NeRF 1's blend
    const RenderTargets t = random_targets(in, 62);
    const DeviceRender d = run_device_render(in, t);
    const size_t R = in.rays, S = in.samples, C = in.channels;
    std::vector<double> fd(d.grad_raw.size(), 0.0);
    double scale = 0;
    for (size_t r = 0; r < R; ++r) {
      RayProblem p = ray_problem(in, t, static_cast<int>(r));
      for (size_t n = 0; n < static_cast<size_t>(nerfs); ++n)
        for (size_t i = 0; i < S; ++i) {
          double& x = p.in.raw[(n * S + i) * C + 4];
          const double x0 = x, h = 1e-3;
          x = x0 + h;
          const double lp = ray_loss(p);
          x = x0 - h;
          const double lm = ray_loss(p);
          x = x0;
          const size_t e = ((n * R + r) * S + i) * C + 4;
          fd[e] = (lp - lm) / (2 * h);
          scale = std::max(scale, std::fabs(fd[e]));
        }
    }
    BOOST_TEST_REQUIRE(scale > 0.0);
    double worst = 0;
    size_t worst_e = 0;
    for (size_t e = 4; e < fd.size(); e += C) {
      const double err = std::fabs(d.grad_raw[e] - fd[e]) / (1e-3 * std::fabs(fd[e]) + 1e-4 * scale);
      if (!(err <= worst)) {
        worst = std::isnan(err) ? INFINITY : err;
        worst_e = e;
      }
    }
    BOOST_TEST_MESSAGE(nerfs << " NeRF(s): largest blend gradient " << scale << ", worst error " << worst
                             << " of the tolerance");
    BOOST_TEST(worst <= 1.0, nerfs << " NeRF(s): d loss / d blend[" << worst_e << "] is " << d.grad_raw[worst_e]
                                   << ", float64 finite difference " << fd[worst_e]);
  }
}

BOOST_AUTO_TEST_SUITE_END()

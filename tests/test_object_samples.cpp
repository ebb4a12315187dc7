// Samples where the objects are (sample_warp.hpp, object_samples.hpp): the warp's knots hold
// the mixture they promise, warped stratified samples against a float64 inverse of that
// mixture (found by bisection, not from the knots), and an object's depth range. The device
// warp of a training step is the op table's object_sample_warp entry; training and resuming
// with it, test_train.cpp; the option, test_object_box.cpp.
#include <boost/test/unit_test.hpp>
#include <algorithm>
#include <cmath>

#include "harness.hpp"
#include "nova/graph/executor.hpp"
#include "nova/model/object_samples.hpp"
#include "nova/sampling/rays.hpp"
#include "nova/sampling/sample_warp.hpp"
#include "rays_reference.hpp"

using namespace nova;
using namespace nova::test;

namespace {

// The mixture's cumulative distribution at t, straight from its definition.
double mixture_cdf(const std::vector<DepthInterval>& intervals, double share, double t) {
  double c = (1.0 - share) * t;
  for (const DepthInterval& i : intervals)
    c += share / static_cast<double>(intervals.size()) * std::clamp((t - i.lo) / (i.hi - i.lo), 0.0, 1.0);
  return c;
}

double mixture_inverse(const std::vector<DepthInterval>& intervals, double share, double u) {
  double lo = 0.0, hi = 1.0;
  for (int k = 0; k < 80; ++k) {
    const double mid = 0.5 * (lo + hi);
    (mixture_cdf(intervals, share, mid) < u ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

std::vector<std::array<double, 2>> knots_of(const std::vector<float>& w) {
  std::vector<std::array<double, 2>> k;
  for (size_t i = 0; i + 1 < w.size(); i += 2) k.push_back({w[i], w[i + 1]});
  return k;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(object_samples)

BOOST_AUTO_TEST_CASE(the_warp_puts_its_share_in_the_intervals) {
  // Half the samples over [0.3, 0.4] and [0.6, 0.65], a quarter each: the cumulative
  // distribution at the bounds, by hand.
  const auto k = knots_of(sample_warp({{0.3, 0.4}, {0.6, 0.65}}, 0.5));
  const std::vector<std::array<double, 2>> want = {{0, 0}, {0.15, 0.3}, {0.45, 0.4}, {0.55, 0.6}, {0.825, 0.65}, {1, 1}};
  BOOST_REQUIRE(k.size() == want.size());
  for (size_t i = 0; i < k.size(); ++i) {
    BOOST_TEST(std::abs(k[i][0] - want[i][0]) < 1e-6, "knot " << i << " u " << k[i][0]);
    BOOST_TEST(std::abs(k[i][1] - want[i][1]) < 1e-6, "knot " << i << " t " << k[i][1]);
  }
  // Overlapping intervals add their densities; the knots stay increasing and end at (1, 1).
  const auto o = knots_of(sample_warp({{0.2, 0.5}, {0.4, 0.7}}, 0.6));
  BOOST_REQUIRE(o.size() == 6u);
  for (size_t i = 1; i < o.size(); ++i) {
    BOOST_TEST(o[i][0] >= o[i - 1][0]);
    BOOST_TEST(o[i][1] >= o[i - 1][1]);
  }
  for (size_t i = 0; i < o.size(); ++i)
    BOOST_TEST(std::abs(o[i][0] - mixture_cdf({{0.2, 0.5}, {0.4, 0.7}}, 0.6, o[i][1])) < 1e-6);
  BOOST_TEST(o.back()[0] == 1.0);
  BOOST_TEST(o.back()[1] == 1.0);
}

BOOST_AUTO_TEST_CASE(intervals_outside_or_empty_give_their_share_back) {
  // No interval, an empty one, a NaN one and one wholly past the far end: the identity, its
  // unused knots at (1, 1).
  for (const std::vector<DepthInterval>& none :
       {std::vector<DepthInterval>{}, {{0.5, 0.5}}, {{NAN, 0.4}}, {{1.2, 1.5}}}) {
    const auto k = knots_of(sample_warp(none, 0.5));
    BOOST_REQUIRE(k.size() == sample_warp_knots(none.size()));
    BOOST_TEST(k[0][0] == 0.0);
    BOOST_TEST(k[0][1] == 0.0);
    for (size_t i = 1; i < k.size(); ++i) {
      BOOST_TEST(k[i][0] == 1.0);
      BOOST_TEST(k[i][1] == 1.0);
    }
  }
  // Clipped to [0, 1]; a sliver narrower than kMinWarpInterval widened about its middle.
  const auto c = knots_of(sample_warp({{-0.5, 0.1}}, 0.5));
  BOOST_TEST(std::abs(c[1][0] - (0.05 + 0.5)) < 1e-6);
  BOOST_TEST(std::abs(c[1][1] - 0.1) < 1e-7);
  const auto s = knots_of(sample_warp({{0.5, 0.5 + 1e-6}}, 0.5));
  BOOST_TEST(std::abs((s[2][1] - s[1][1]) - kMinWarpInterval) < 1e-6);
  BOOST_CHECK_THROW(sample_warp({}, 1.0), Error);
}

// Tolerance: the kernel interpolates float knots in float32 (a few ulp of values in [0, 1]);
// in an interval the warp's slope is below 1, so depths land within 1e-6 of the float64
// inverse, and 2e-6 is kept. Positions are o + z d with NDC values of order 1.
BOOST_AUTO_TEST_CASE(warped_samples_follow_the_mixture) {
  const std::vector<Camera> cams = {make_camera(100, 32, 24, {0, 0, 0}, 0.0, 0.0),
                                    make_camera(100, 32, 24, {0.1, 0, 0}, 0.1, 0.0)};
  const size_t R = 5, S = 48, N = 2;
  const std::vector<DepthInterval> intervals = {{0.62, 0.68}, {0.7, 0.705}};
  const double share = 16.0 / 48.0;
  for (bool jittered : {false, true}) {
    Graph g;
    Tensor p = g.input("pixels", Shape{R, 2}), c = g.input("cameras", Shape{N, 16});
    Tensor j = jittered ? g.input("jitter", Shape{R, S}) : Tensor{};
    Tensor w = g.input("warp", Shape{sample_warp_knots(intervals.size()), 2});
    RayOptions ro;
    ro.ndc = true;
    Rays rays = generate_rays(p, c, ro);
    SampleOptions so;
    so.samples = static_cast<int>(S);
    so.groups = {1, 1};
    Samples s = stratified_samples(rays, j, so, w);
    for (Tensor t : {rays.origins, rays.directions, s.z, s.delta, s.positions[1]}) g.keep(t);
    Executor ex(runtime(), g);
    const auto pixels = random_pixels(R, 32, 24, 41);
    const auto jitter = jittered ? random_floats(R * S, 0, 1, 42) : std::vector<float>{};
    ex.set(p, pixels);
    ex.set(c, camera_rows(cams));
    if (jittered) ex.set(j, jitter);
    ex.set(w, sample_warp(intervals, share));
    ex.forward();
    const std::vector<double> u = ref_depths(R, S, 0.0, 1.0, jitter);
    std::vector<double> z(R * S);
    for (size_t i = 0; i < z.size(); ++i) z[i] = mixture_inverse(intervals, share, u[i]);
    expect_close(ex.get(s.z), z, 2e-6, 0, jittered ? "z, jittered" : "z");
    const auto o = ex.get(rays.origins), d = ex.get(rays.directions), delta = ex.get(s.delta);
    std::vector<double> pos, gap;
    for (size_t r = 0; r < R; ++r)
      for (size_t i = 0; i < S; ++i) {
        const size_t ray = (R + r) * 3;  // NeRF 1's ray
        for (int k = 0; k < 3; ++k) pos.push_back(o[ray + k] + z[r * S + i] * d[ray + k]);
      }
    for (size_t n = 0; n < N; ++n)
      for (size_t r = 0; r < R; ++r) {
        const float* dn = &d[(n * R + r) * 3];
        const double norm = std::sqrt(double(dn[0]) * dn[0] + double(dn[1]) * dn[1] + double(dn[2]) * dn[2]);
        for (size_t i = 0; i < S; ++i) gap.push_back((i + 1 < S ? z[r * S + i + 1] - z[r * S + i] : 1e10) * norm);
      }
    expect_close(ex.get(s.positions[1]), pos, 1e-5, 0, "positions of NeRF 1");
    expect_close(delta, gap, 1e-5, 1e-5, "delta");
    // A third of the samples in the two intervals (0.11 of the range) instead of 0.11 of them.
    size_t inside = 0;
    for (double t : z) inside += (t >= 0.62 && t <= 0.68) || (t >= 0.7 && t <= 0.705);
    const double expected = (1.0 - share) * 0.065 + share;
    BOOST_TEST(std::abs(static_cast<double>(inside) / z.size() - expected) < 2.0 / S, "inside " << inside);
  }
}

BOOST_AUTO_TEST_CASE(an_object_range_is_its_depths_about_the_pivot) {
  // World depths 2.5 to 3.5 about a centre at z = -3: t = 1 - 1 / depth at both ends; a range
  // across the near plane starts at t = 0, one wholly in front of it is empty.
  const DepthInterval in = depth_interval({0.4, -0.2, -3.0}, 0.5);
  BOOST_TEST(std::abs(in.lo - (1.0 - 1.0 / 2.5)) < 1e-15);
  BOOST_TEST(std::abs(in.hi - (1.0 - 1.0 / 3.5)) < 1e-15);
  const DepthInterval near = depth_interval({0, 0, -1.2}, 0.5);
  BOOST_TEST(near.lo == 0.0);
  BOOST_TEST(std::abs(near.hi - (1.0 - 1.0 / 1.7)) < 1e-15);
  const DepthInterval before = depth_interval({0, 0, -0.3}, 0.5);
  BOOST_TEST(!(before.hi > before.lo));
  // A view's warp shares object_samples / samples over the ranges at kObjectSampleRadii radii.
  ModelConfig c;
  c.samples = 48;
  c.object_samples = 16;
  const auto k = knots_of(object_sample_warp(c, {{0.4, -0.2, -3.0}}, {0.25}));
  BOOST_REQUIRE(k.size() == 4u);
  BOOST_TEST(std::abs(k[1][1] - in.lo) < 1e-7);
  BOOST_TEST(std::abs(k[2][1] - in.hi) < 1e-7);
  BOOST_TEST(std::abs((k[2][0] - k[1][0]) - (32.0 / 48.0 * (in.hi - in.lo) + 16.0 / 48.0)) < 1e-6);
}

BOOST_AUTO_TEST_SUITE_END()

// The free-space loss against a float64 reference (tests/free_space_reference.hpp): forward,
// the gradient of raw against central differences of that reference, that the rendered depth
// (which only places the target) gets no gradient from it, and what it is for: a haze in
// front of the disparity's surface costs, the same opacity at the surface does not, and with
// `behind` set the same opacity behind the surface costs as well.
//
// Tolerances: the loss sums at most N R S = 3 x 37 x 11 float32 products of O(1) values, so
// rtol 1e-4. Gradients: the analytic sigma gradient of the device against float64 central
// differences (h = 1e-4 on sigmas kept >= 0.3 from the ReLU kink, so no kink is crossed):
// truncation O(h^2) ~1e-8 and float32 chains of S = 11 terms, atol 1e-5 of the gradient's
// scale, rtol 1e-3.
#include <boost/test/unit_test.hpp>

#include "free_space_reference.hpp"
#include "harness.hpp"
#include "nova/executor.hpp"
#include "nova/losses.hpp"
#include "nova/ops.hpp"

using namespace nova;
using namespace nova::test;

namespace {

FreeSpaceCase make_case(size_t N, size_t R, size_t S, bool noise, unsigned seed) {
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

FreeSpaceRun run_device(const FreeSpaceCase& f, bool depth_also_in_mse = false) {
  return run_free_space(f, test::runtime(), depth_also_in_mse);
}

}  // namespace

BOOST_AUTO_TEST_SUITE(free_space_loss_op)

BOOST_AUTO_TEST_CASE(forward_and_gradient_match_reference) {
  for (int variant = 0; variant < 3; ++variant) {
    const bool noise = variant == 1;
    FreeSpaceCase f = make_case(3, 37, 11, noise, 10 * (variant + 1));
    f.behind = variant == 2 ? 0.7f : 0.0f;  // weight behind the surface costs too
    const FreeSpaceRun d = run_device(f);
    const double ref = free_space_reference(f, f.raw);
    BOOST_TEST(ref > 1e-3);  // the case has weight in front of its targets
    expect_close({d.loss}, {ref}, 0, 1e-4, "free_space_loss");
    const std::vector<double> fd = free_space_sigma_fd(f, 1e-4f);
    double scale = 0;
    for (double v : fd) scale = std::max(scale, std::abs(v));
    expect_close(d.d_raw, fd, 1e-5 * scale, 1e-3,
                 variant == 0 ? "d raw" : variant == 1 ? "d raw (noise)" : "d raw (behind)");
  }
}

BOOST_AUTO_TEST_CASE(depth_gets_no_gradient) {
  const FreeSpaceCase f = make_case(3, 17, 7, false, 30);
  const FreeSpaceRun d = run_device(f, true);
  std::vector<double> ref(f.R);
  for (size_t r = 0; r < f.R; ++r) ref[r] = 2.0 * f.depth[r] / double(f.R);  // mse(depth, 0) alone
  expect_close(d.d_depth, ref, 1e-7, 1e-5, "d depth");
}

BOOST_AUTO_TEST_CASE(haze_in_front_costs_a_surface_does_not) {
  // One object NeRF (N = 2, NeRF 0 static and exempt), one valid ray pair; rays 0 and 1 have
  // the same target, so the target is the mean depth and lands at the depth's own value.
  FreeSpaceCase f;
  f.N = 2, f.R = 2, f.S = 20;
  f.margin = 0.05f;
  f.depth = {0.6f, 0.6f};
  f.target = {-1.0f, -1.0f};
  f.valid = {1.0f, 1.0f};
  f.masks = {1, 1, 1, 1};
  f.per_nerf_delta = false;
  f.delta.assign(f.R * f.S, 0.05f);
  for (size_t r = 0; r < f.R; ++r)
    for (size_t i = 0; i < f.S; ++i) f.z.push_back(0.05f * i);
  f.raw.assign(f.N * f.R * f.S * f.C, 0.0f);
  // Ray 0 of the object: opaque at z = 0.6 (sample 12). Ray 1: the same opacity at z = 0.3.
  f.raw[((1 * f.R + 0) * f.S + 12) * f.C + 3] = 200.0f;
  f.raw[((1 * f.R + 1) * f.S + 6) * f.C + 3] = 200.0f;
  const FreeSpaceRun d = run_device(f);
  // Ray 1's weight ~1 sits 0.6 - 0.05 - 0.3 = 0.25 in front: loss 0.25 / (1 x 2 rays).
  BOOST_TEST(d.loss == 0.125, boost::test_tools::tolerance(1e-3));
  f.raw[((1 * f.R + 1) * f.S + 6) * f.C + 3] = 0.0f;
  f.raw[((1 * f.R + 1) * f.S + 12) * f.C + 3] = 200.0f;
  BOOST_TEST(run_device(f).loss == 0.0f);
  // The same opacity behind the surface, at z = 0.9 (sample 18): free unless `behind` is set,
  // then 0.9 - 0.6 - 0.05 = 0.25 of distance at weight 2 for one of the two rays.
  f.raw[((1 * f.R + 1) * f.S + 12) * f.C + 3] = 0.0f;
  f.raw[((1 * f.R + 1) * f.S + 18) * f.C + 3] = 200.0f;
  BOOST_TEST(run_device(f).loss == 0.0f);
  f.behind = 2.0f;
  BOOST_TEST(run_device(f).loss == 0.25, boost::test_tools::tolerance(1e-3));
}

BOOST_AUTO_TEST_SUITE_END()

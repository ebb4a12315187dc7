// The free-space loss: that the rendered depth (which only places the target) gets no
// gradient from it, and what it is for: a haze in front of the disparity's surface costs, the
// same opacity at the surface does not, and with `behind` set the same opacity behind the
// surface costs as well. Its forward and sigma gradient against the float64 reference
// (tests/free_space_reference.hpp), with and without noise and `behind`, are the op table's
// free_space_loss entry (tests/op_table_ray_losses.cpp, checked in op_table_checks.cpp).
//
// Tolerance of the depth's gradient: the mse's 2 depth / R alone, float32 of two roundings.
#include <boost/test/unit_test.hpp>

#include "free_space_reference.hpp"
#include "harness.hpp"
#include "nova/graph/executor.hpp"
#include "nova/loss/terms.hpp"

using namespace nova;
using namespace nova::test;

namespace {

FreeSpaceRun run_device(const FreeSpaceCase& f, bool depth_also_in_mse = false) {
  return run_free_space(f, test::runtime(), depth_also_in_mse);
}

}  // namespace

BOOST_AUTO_TEST_SUITE(free_space_loss_op)

BOOST_AUTO_TEST_CASE(depth_gets_no_gradient) {
  const FreeSpaceCase f = free_space_random_case(3, 17, 7, false, 30);
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

// The depth loss up to scale and shift: invalid rays that count for nothing, and its
// invariances (the op against its float64 reference and central differences, at 57, 23 and
// 1009 rays: the op table, tests/op_table_losses.cpp).
//
// Tolerances: the loss is a mean of squared differences of standardised values (each O(1));
// float32 sums over R = 57 rays carry a relative error of a few 1e-6, so rtol 1e-4.
#include <boost/test/unit_test.hpp>
#include <cmath>

#include "harness.hpp"
#include "loss_reference.hpp"
#include "nova/graph/executor.hpp"
#include "nova/loss/terms.hpp"

using namespace nova;
using nova::test::random_floats;

namespace {

double reference(const std::vector<float>& p, const std::vector<float>& t, const std::vector<float>& w) {
  return test::ref_depth_loss(test::to_double(p), t, w);
}

float device_loss(const std::vector<float>& p, const std::vector<float>& t,
                  const std::vector<float>& w) {
  Graph g;
  const Shape s{p.size()};
  Tensor tp = g.input("depth", s), tt = g.input("target", s), tw = g.input("valid", s);
  Tensor loss = depth_loss(tp, tt, tw);
  g.keep(loss);
  Executor ex(test::runtime(), g);
  ex.set(tp, p);
  ex.set(tt, t);
  ex.set(tw, w);
  ex.forward();
  return ex.get(loss).at(0);
}

std::vector<float> every_fifth_invalid(size_t n) {
  std::vector<float> w(n, 1.0f);
  for (size_t i = 0; i < n; i += 5) w[i] = 0.0f;
  return w;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(depth_loss_op)

BOOST_AUTO_TEST_CASE(forward_matches_reference) {
  const size_t R = 57;
  const auto p = random_floats(R, 0.0f, 1.0f, 1), t = random_floats(R, -2.0f, 3.0f, 2);
  const auto w = every_fifth_invalid(R);
  const double ref = reference(p, t, w);
  BOOST_TEST(device_loss(p, t, w) == ref, boost::test_tools::tolerance(1e-4));
  // Invalid rays do not count: changing them changes nothing.
  auto p2 = p;
  for (size_t i = 0; i < R; i += 5) p2[i] = 100.0f;
  BOOST_TEST(device_loss(p2, t, w) == ref, boost::test_tools::tolerance(1e-4));
}

BOOST_AUTO_TEST_CASE(invariant_to_scale_and_shift) {
  // A target affine in the depth (positive slope) gives 0; a negative slope gives ~4.
  const size_t R = 41;
  const auto p = random_floats(R, 0.2f, 0.9f, 3);
  std::vector<float> t(R), u(R);
  for (size_t r = 0; r < R; ++r) t[r] = 7.0f * p[r] - 3.0f, u[r] = -2.0f * p[r] + 1.0f;
  const std::vector<float> w(R, 1.0f);
  BOOST_TEST(device_loss(p, t, w) < 1e-4);
  BOOST_TEST(std::fabs(device_loss(p, u, w) - 4.0f) < 1e-2);
  // Fewer than two valid rays: no information, no loss.
  std::vector<float> one(R, 0.0f);
  one[3] = 1.0f;
  BOOST_TEST(device_loss(p, u, one) == 0.0f);
}

BOOST_AUTO_TEST_SUITE_END()

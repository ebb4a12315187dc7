// The sparsity loss (L1 on object alpha inside its mask) against a float64 reference, and
// central finite differences of the device forward.
//
// Tolerances: a mean of N*R*S values in [0, 1], each a few float32 roundings from its float64
// value (expm1 within 4 ulp), so rtol 1e-5. Gradients: harness default (2e-2 of the
// gradient's scale); sigma + noise is kept 0.05 away from the ReLU kink the stencil would
// cross.
#include <boost/test/unit_test.hpp>
#include <cmath>

#include "harness.hpp"
#include "nova/executor.hpp"
#include "nova/losses.hpp"
#include "nova/render.hpp"

using namespace nova;
using nova::test::OpUnderTest;
using nova::test::random_floats;

namespace {

constexpr size_t N = 3, R = 7, S = 5, C = kRawChannels;

std::vector<float> raw_values(unsigned seed) {
  auto raw = random_floats(N * R * S * C, -2.0f, 2.0f, seed);
  for (size_t e = 0; e < N * R * S; ++e) {
    float& sigma = raw[e * C + kRawSigma];
    if (std::fabs(sigma) < 0.05f) sigma = 0.05f;
  }
  return raw;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(sparsity_loss_op)

BOOST_AUTO_TEST_CASE(forward_matches_reference) {
  const auto raw = raw_values(1);
  const auto delta = random_floats(R * S, 0.05f, 0.5f, 2);
  const auto masks = random_floats(N * R, 0.0f, 1.0f, 3);
  Graph g;
  Tensor traw = g.input("raw", Shape{N, R * S, C});
  Tensor tdelta = g.input("delta", Shape{R, S});
  Tensor tmasks = g.input("masks", Shape{N, R});
  Tensor loss = sparsity_loss(traw, tdelta, tmasks);
  g.keep(loss);
  Executor ex(test::runtime(), g);
  ex.set(traw, raw);
  ex.set(tdelta, delta);
  ex.set(tmasks, masks);
  ex.forward();
  double ref = 0;
  for (size_t n = 1; n < N; ++n)  // the static NeRF (n = 0) is exempt
    for (size_t r = 0; r < R; ++r)
      for (size_t i = 0; i < S; ++i) {
        const double sigma = std::max(0.0, double(raw[((n * R + r) * S + i) * C + kRawSigma]));
        ref += masks[n * R + r] * -std::expm1(-sigma * delta[r * S + i]);
      }
  ref /= double((N - 1) * R * S);
  BOOST_TEST(ex.get(loss).at(0) == ref, boost::test_tools::tolerance(1e-5));
}

BOOST_AUTO_TEST_CASE(gradient) {
  test::check_gradients(
      [&](Graph& g) {
        Tensor raw = g.input("raw", Shape{N, R * S, C}, true);
        Tensor delta = g.input("delta", Shape{R, S});
        Tensor masks = g.input("masks", Shape{N, R});
        return OpUnderTest{{raw, delta, masks}, sparsity_loss(raw, delta, masks)};
      },
      {raw_values(4), random_floats(R * S, 0.05f, 0.5f, 5), random_floats(N * R, 0.0f, 1.0f, 6)});
}

BOOST_AUTO_TEST_SUITE_END()

// The distortion loss's two closed forms (one opaque sample, two equal weights at the ends of
// the ray) and the shapes it refuses. Against its float64 reference (distortion_reference.hpp,
// every sample pair summed directly; the kernel walks prefix sums) with and without masks and
// noise, and by central differences of the device forward: the op table,
// tests/op_table_losses.cpp.
#include <boost/test/unit_test.hpp>
#include <algorithm>
#include <cmath>

#include "distortion_reference.hpp"
#include "harness.hpp"
#include "nova/graph/executor.hpp"
#include "nova/loss/terms.hpp"
#include "nova/render/render_composite.hpp"

using namespace nova;
using nova::test::OpUnderTest;
using nova::test::random_floats;

namespace {

constexpr size_t N = 3, R = 6, S = 9, C = kRawChannels;

using Inputs = test::DistortionInputs;

Inputs make_inputs(unsigned seed) { return test::distortion_inputs(N, R, S, seed); }

float run_loss(const Inputs& in, bool masks, bool noise, size_t first = 0) {
  std::vector<std::vector<float>> values = {in.raw, in.delta, in.z};
  if (masks) values.push_back(in.masks);
  if (noise) values.push_back(in.noise);
  return test::run_forward(
             [&](Graph& g) {
               Tensor raw = g.input("raw", Shape{N, R * S, C});
               Tensor delta = g.input("delta", Shape{N, R, S});
               Tensor z = g.input("z", Shape{R, S});
               Tensor m = masks ? g.input("masks", Shape{N, R}) : Tensor{};
               Tensor nz = noise ? g.input("noise", Shape{N, R * S}) : Tensor{};
               std::vector<Tensor> inputs = {raw, delta, z};
               if (masks) inputs.push_back(m);
               if (noise) inputs.push_back(nz);
               return OpUnderTest{inputs, distortion_loss(raw, delta, z, m, nz, first)};
             },
             values)
      .at(0);
}

}  // namespace

BOOST_AUTO_TEST_SUITE(distortion_loss_op)

BOOST_AUTO_TEST_CASE(closed_forms) {
  Inputs in = make_inputs(21);
  // Every ray opaque at one sample and empty elsewhere: no spread, no loss.
  for (size_t e = 0; e < N * R * S; ++e) in.raw[e * C + kRawSigma] = (e % S == 4) ? 1e4f : -1.0f;
  BOOST_TEST(run_loss(in, false, false) == 0.0f);
  // Half the weight at the first sample (alpha 1/2), the rest at the last (opaque): the
  // pairs (0, S-1) and (S-1, 0) give 2 * 1/2 * 1/2 * |1 - 0| = 1/2 on every ray.
  for (size_t e = 0; e < N * R * S; ++e) {
    const size_t i = e % S;
    in.raw[e * C + kRawSigma] = i == 0 ? 1.0f : (i == S - 1 ? 1.0f : -1.0f);
    in.delta[e] = i == 0 ? std::log(2.0f) : (i == S - 1 ? 1e10f : 0.1f);
  }
  BOOST_TEST(run_loss(in, false, false) == 0.5f, boost::test_tools::tolerance(1e-6f));
}

BOOST_AUTO_TEST_CASE(bad_shapes_are_refused) {
  Graph g;
  Tensor raw = g.input("raw", Shape{N, R * S, C});
  Tensor delta = g.input("delta", Shape{N, R, S});
  BOOST_CHECK_THROW(distortion_loss(raw, delta, g.input("z", Shape{R, S + 1})), Error);
  Tensor z = g.input("z2", Shape{R, S});
  BOOST_CHECK_THROW(distortion_loss(raw, delta, z, g.input("m", Shape{N, R + 1})), Error);
  BOOST_CHECK_THROW(distortion_loss(raw, g.input("d2", Shape{2, R, S}), z), Error);
  BOOST_CHECK_THROW(distortion_loss(raw, delta, z, Tensor{}, Tensor{}, N), Error);
}

BOOST_AUTO_TEST_SUITE_END()

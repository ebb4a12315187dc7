// The distortion loss against a float64 reference that sums all sample pairs directly (the
// kernel walks prefix sums), its two closed forms (one opaque sample, two equal weights at
// the ends of the ray), and central finite differences of the device forward.
//
// Tolerances: the kernel forms each pair sum as u_i W_<i - WU_<i from float32 prefix sums of
// weights <= 1, an absolute error of a few 2^-24 per sample, S per ray: atol 1e-6 on a mean
// of terms of size ~0.1, plus rtol 1e-5 for the float32 transmittance products. Gradients:
// the harness default (2e-2 of the gradient's scale); sigma + noise is kept 0.05 away from
// the ReLU kink the stencil (step 1e-2) would cross.
#include <boost/test/unit_test.hpp>
#include <algorithm>
#include <cmath>

#include "harness.hpp"
#include "nova/executor.hpp"
#include "nova/losses.hpp"
#include "nova/render.hpp"

using namespace nova;
using nova::test::OpUnderTest;
using nova::test::random_floats;

namespace {

constexpr size_t N = 3, R = 6, S = 9, C = kRawChannels;

struct Inputs {
  std::vector<float> raw, delta, z, masks, noise;
};

// Sigma in [-2, 4] with sigma + noise clear of 0; z increasing per ray from a random start;
// delta per NeRF, its last sample 1e10 as the sampler's (that sample is opaque wherever
// sigma + noise > 0).
Inputs make_inputs(unsigned seed) {
  Inputs in;
  in.raw = random_floats(N * R * S * C, -2.0f, 4.0f, seed);
  in.noise = random_floats(N * R * S, -0.5f, 0.5f, seed + 1);
  for (size_t e = 0; e < N * R * S; ++e) {
    float& sigma = in.raw[e * C + kRawSigma];
    if (std::fabs(sigma + in.noise[e]) < 0.05f) sigma += 0.1f;
  }
  const auto start = random_floats(R, 0.0f, 0.3f, seed + 2);
  const auto gaps = random_floats(R * S, 0.02f, 0.15f, seed + 3);
  in.z.resize(R * S);
  for (size_t r = 0; r < R; ++r) {
    float z = start[r];
    for (size_t i = 0; i < S; ++i) z = in.z[r * S + i] = z + gaps[r * S + i];
  }
  in.delta = random_floats(N * R * S, 0.02f, 0.3f, seed + 4);
  for (size_t n = 0; n < N; ++n)
    for (size_t r = 0; r < R; ++r) in.delta[(n * R + r) * S + S - 1] = 1e10f;
  in.masks = random_floats(N * R, 0.0f, 1.0f, seed + 5);
  in.masks[1] = 0.0f;  // a ray outside NeRF 0's region
  return in;
}

double reference(const Inputs& in, bool masks, bool noise, size_t first = 0) {
  double total = 0;
  for (size_t n = first; n < N; ++n)
    for (size_t r = 0; r < R; ++r) {
      std::vector<double> w(S), u(S);
      double T = 1;
      const double z0 = in.z[r * S], span = in.z[r * S + S - 1] - z0;
      for (size_t i = 0; i < S; ++i) {
        const size_t e = (n * R + r) * S + i;
        const double sigma = std::max(0.0, double(in.raw[e * C + kRawSigma]) + (noise ? in.noise[e] : 0.0));
        const double alpha = -std::expm1(-sigma * in.delta[e]);
        w[i] = T * alpha;
        T *= 1 - alpha;
        u[i] = (in.z[r * S + i] - z0) / span;
      }
      double pairs = 0;
      for (size_t i = 0; i < S; ++i)
        for (size_t j = 0; j < S; ++j) pairs += w[i] * w[j] * std::fabs(u[i] - u[j]);
      total += (masks ? in.masks[n * R + r] : 1.0) * pairs;
    }
  return total / double((N - first) * R);
}

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

BOOST_AUTO_TEST_CASE(forward_matches_reference) {
  const Inputs in = make_inputs(11);
  for (bool masks : {false, true})
    for (bool noise : {false, true})
      for (size_t first : {0, 1}) {  // 1: the object NeRFs alone, as training uses it
        const double ref = reference(in, masks, noise, first);
        BOOST_TEST_CONTEXT("masks " << masks << " noise " << noise << " first NeRF " << first) {
          BOOST_TEST(ref > 1e-3);  // the inputs spread weight along the rays
          BOOST_TEST(std::fabs(run_loss(in, masks, noise, first) - ref) <= 1e-6 + 1e-5 * ref);
        }
      }
}

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

BOOST_AUTO_TEST_CASE(gradient) {
  for (bool masks : {false, true}) {
    const Inputs in = make_inputs(31 + masks);
    const size_t first = masks ? 1 : 0;  // NeRF 0 left out: its gradient must be 0
    BOOST_TEST_CONTEXT("masks " << masks << " first NeRF " << first) {
      std::vector<std::vector<float>> values = {in.raw, in.delta, in.z};
      if (masks) values.push_back(in.masks);
      values.push_back(in.noise);
      test::check_gradients(
          [&](Graph& g) {
            Tensor raw = g.input("raw", Shape{N, R * S, C}, true);
            Tensor delta = g.input("delta", Shape{N, R, S});
            Tensor z = g.input("z", Shape{R, S});
            Tensor m = masks ? g.input("masks", Shape{N, R}) : Tensor{};
            Tensor nz = g.input("noise", Shape{N, R * S});
            std::vector<Tensor> inputs = {raw, delta, z};
            if (masks) inputs.push_back(m);
            inputs.push_back(nz);
            return OpUnderTest{inputs, distortion_loss(raw, delta, z, m, nz, first)};
          },
          values);
    }
  }
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

#pragma once
// Float64 reference of the distortion loss (include/nova/loss/terms.hpp, kernels/distortion_loss.cl):
// every sample pair summed directly (the kernel walks prefix sums), and the inputs the tests
// draw for it.
#include <algorithm>
#include <cmath>
#include <vector>

#include "harness.hpp"
#include "nova/render/render_composite.hpp"

namespace nova::test {

struct DistortionInputs {
  size_t N = 0, R = 0, S = 0;
  std::vector<float> raw, delta, z, masks, noise;
};

// Sigma in [-2, 4] with sigma + noise clear of 0; z increasing per ray from a random start;
// delta per NeRF, its last sample 1e10 as the sampler's (that sample is opaque wherever
// sigma + noise > 0).
inline DistortionInputs distortion_inputs(size_t N, size_t R, size_t S, unsigned seed) {
  constexpr size_t C = kRawChannels;
  DistortionInputs in;
  in.N = N, in.R = R, in.S = S;
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
  if (R > 1) in.masks[1] = 0.0f;  // a ray outside NeRF 0's region
  return in;
}

inline double distortion_reference(const DistortionInputs& in, bool masks, bool noise, size_t first = 0) {
  constexpr size_t C = kRawChannels;
  const size_t N = in.N, R = in.R, S = in.S;
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

}  // namespace nova::test

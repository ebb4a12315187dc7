#pragma once
// The float64 reference of random.hpp's draws: value g of a draw is element g % 4 of the
// Philox4x32-10 block (g / 4, 0, counter) under the key (seed, stream); uniform values are
// its top 24 bits, normal values Box-Muller on the block's pairs (cosine for elements 0 and
// 2, sine for 1 and 3).
#include <cmath>
#include <cstdint>

#include "nova/sampling/random.hpp"

namespace nova::test {

inline double unit_from_bits(uint32_t x, bool open0) { return double((x >> 8) + (open0 ? 1u : 0u)) / 16777216.0; }

inline double random_reference(bool normal, uint64_t g, uint32_t seed, uint32_t stream, uint64_t counter,
                               double scale = 1.0) {
  const auto r = philox4x32_10({uint32_t(g / 4), uint32_t(g >> 34), uint32_t(counter), uint32_t(counter >> 32)},
                               {seed, stream});
  if (!normal) return scale * unit_from_bits(r[g % 4], false);
  const size_t pair = (g % 4) / 2;
  const double rad = std::sqrt(-2.0 * std::log(unit_from_bits(r[2 * pair], true)));
  const double theta = 2.0 * M_PI * unit_from_bits(r[2 * pair + 1], false);
  return scale * rad * (g % 2 == 0 ? std::cos(theta) : std::sin(theta));
}

}  // namespace nova::test

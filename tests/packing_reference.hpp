#pragma once
// Float64 (integer) reference of the packing ops (include/nova/sampling/occupancy.hpp,
// kernels/packing.cl): which rows a select keeps, and the grids the tests select with.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "nova/sampling/occupancy.hpp"

namespace nova::test {

// A grid with a checkerboard of occupied cells (every cell evaluated).
inline OccupancyGrid checker_grid(int res, int phase) {
  OccupancyGrid g(res, 1.0f, 0.01f);
  const size_t r = static_cast<size_t>(res);
  for (size_t c = 0; c < g.cells(); ++c) {
    const size_t x = c % r, y = (c / r) % r, z = c / (r * r);
    g.density[c] = (x + y + z + static_cast<size_t>(phase)) % 2 ? 10.0f * g.threshold() : 0.0f;
  }
  g.refresh();
  return g;
}

// Early termination's rules on top of the grids (SampleRange): sample index m % S in
// [first, end) of rays m / S that are open (`open`: the host copy of the range's flags, empty
// when it has none). Plain integer logic, the reference of the pack kernels.
inline bool in_sample_range(const PackSelect& s, const std::vector<uint8_t>& open, size_t m) {
  const SampleRange& g = s.range;
  if (g.samples_per_ray == 0) return true;
  const size_t i = m % g.samples_per_ray, r = m / g.samples_per_ray;
  return i >= g.first && i < g.end && (open.empty() || open[r]);
}

// The kept rows of `rows` per batch: grids (when enabled) and the sample range.
inline std::vector<std::vector<size_t>> reference_range_kept(const std::vector<float>& pos, const PackSelect& s,
                                                             const std::vector<uint8_t>& open, size_t batches,
                                                             size_t rows) {
  std::vector<std::vector<size_t>> kept(batches);
  for (size_t b = 0; b < batches; ++b)
    for (size_t m = 0; m < rows; ++m) {
      bool keep = in_sample_range(s, open, m);
      if (keep && s.enabled && s.grids) {
        const OccupancyGrid& g = (*s.grids)[static_cast<size_t>(s.grid_of_batch[b])];
        size_t c = 0;
        for (int d = 2; d >= 0; --d) {
          const double u = (double(pos[(b * rows + m) * 3 + d]) + 1.0) / 2.0 * g.resolution;
          const int i = std::clamp(static_cast<int>(std::floor(u)), 0, g.resolution - 1);
          c = c * static_cast<size_t>(g.resolution) + static_cast<size_t>(i);
        }
        keep = g.occupied[c];
      }
      if (keep) kept[b].push_back(m);
    }
  return kept;
}

}  // namespace nova::test

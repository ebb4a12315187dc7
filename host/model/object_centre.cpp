// The centre of an object from its density on a probe grid (see object_centre.hpp).
#include "nova/model/object_centre.hpp"

#include <algorithm>
#include <cmath>

namespace nova {

std::array<double, 3> probe_cell_centre(size_t c, int resolution, double bound) {
  const size_t g = static_cast<size_t>(resolution);
  const size_t idx[3] = {c % g, (c / g) % g, c / (g * g)};
  const double cell = 2.0 * bound / static_cast<double>(resolution);
  std::array<double, 3> p{};
  for (int d = 0; d < 3; ++d) p[d] = -bound + (static_cast<double>(idx[d]) + 0.5) * cell;
  return p;
}

std::array<double, 3> field_to_world(const std::array<double, 3>& p, const CentroidOptions& o) {
  if (!o.ndc) return p;
  const double z = 2.0 * o.ndc_near / std::min(p[2] - 1.0, -1e-6);
  return {p[0] * z / o.ax, p[1] * z / o.ay, z};
}

Centroid density_centroid(const std::vector<float>& density, int resolution, double bound,
                          const CentroidOptions& o) {
  Centroid out;
  const double cell = 2.0 * bound / static_cast<double>(resolution);
  for (float v : density)
    if (std::isfinite(v) && v > 0) out.max_density = std::max(out.max_density, static_cast<double>(v));
  // alpha = 1 - exp(-sigma cell) > a  <=>  sigma > -log(1 - a) / cell.
  const double floor = -std::log1p(-o.floor_alpha) / cell;
  if (!(out.max_density > floor)) return out;  // nothing a render would draw
  const double threshold = std::min(-std::log1p(-o.alpha) / cell, o.max_fraction * out.max_density);
  double sum_w = 0, sum[3] = {0, 0, 0};
  for (size_t c = 0; c < density.size(); ++c) {
    const double sigma = density[c];
    if (!std::isfinite(sigma) || !(sigma > threshold)) continue;
    const std::array<double, 3> p = probe_cell_centre(c, resolution, bound);
    sum_w += sigma;
    for (int d = 0; d < 3; ++d) sum[d] += sigma * p[d];
    ++out.cells;
  }
  if (out.cells == 0 || !(sum_w > 0) || !std::isfinite(sum_w)) return out;
  out.found = true;
  // The mean in field coordinates, then into the world (object_centre.hpp).
  std::array<double, 3> mean{};
  for (int d = 0; d < 3; ++d) mean[d] = sum[d] / sum_w;
  out.field_centre = mean;
  out.centre = field_to_world(mean, o);
  return out;
}

}  // namespace nova

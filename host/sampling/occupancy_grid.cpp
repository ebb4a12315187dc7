#include <algorithm>
#include <atomic>
#include <cmath>

#include "nova/runtime/error.hpp"
#include "nova/sampling/occupancy.hpp"

namespace nova {
namespace {
uint64_t next_generation() {
  static std::atomic<uint64_t> counter{0};
  return ++counter;
}
}  // namespace

OccupancyGrid::OccupancyGrid(int res, float b, float a) : resolution(res), bound(b), alpha(a) {
  if (res < 1 || res > 512) throw Error("occupancy grid: resolution must be in [1, 512], got " + std::to_string(res), kExitUsage);
  if (!(b > 0.0f) || !std::isfinite(b)) throw Error("occupancy grid: bound must be positive", kExitUsage);
  if (!(a > 0.0f && a < 1.0f)) throw Error("occupancy grid: alpha must be in (0, 1), got " + std::to_string(a), kExitUsage);
  const size_t n = static_cast<size_t>(res) * res * res;
  density.assign(n, -1.0f);
  occupied.assign(n, 1);
  generation = next_generation();
}

float OccupancyGrid::threshold() const { return -std::log1p(-alpha) / cell_size(); }

size_t OccupancyGrid::cell_of(const float* p) const {
  const float scale = static_cast<float>(resolution) / (2.0f * bound);
  size_t c = 0;
  for (int d = 2; d >= 0; --d) {
    const float u = (p[d] + bound) * scale;
    // NaN compares false and lands in cell 0; the field clamps the same way. Clamped as a
    // float first: converting a float beyond int's range (a point at infinity) is undefined.
    const int i = u >= 0.0f ? static_cast<int>(std::min(u, static_cast<float>(resolution - 1))) : 0;
    c = c * static_cast<size_t>(resolution) + static_cast<size_t>(i);
  }
  return c;
}

void OccupancyGrid::point_in(size_t c, const float* u, float* p) const {
  const size_t g = static_cast<size_t>(resolution);
  const size_t idx[3] = {c % g, (c / g) % g, c / (g * g)};
  for (int d = 0; d < 3; ++d)
    p[d] = -bound + (static_cast<float>(idx[d]) + u[d]) * cell_size();
}

void OccupancyGrid::update(const std::vector<size_t>& cells, const std::vector<float>& densities, float decay) {
  for (size_t i = 0; i < cells.size(); ++i) {
    float& d = density.at(cells[i]);
    const float v = std::isfinite(densities[i]) ? std::max(densities[i], 0.0f) : 0.0f;
    d = std::max(d < 0.0f ? 0.0f : d * decay, v);
  }
}

void OccupancyGrid::set_support(std::vector<float> box) {
  if (!box.empty() && box.size() != 6) throw Error("occupancy grid: a support box takes 6 numbers", kExitInternal);
  support = std::move(box);
  refresh();
}

void OccupancyGrid::refresh() {
  const float t = threshold();
  for (size_t i = 0; i < density.size(); ++i) occupied[i] = density[i] < 0.0f || density[i] > t;
  if (support.size() == 6) {
    const size_t g = static_cast<size_t>(resolution);
    const float h = cell_size();
    // Per axis, which cell indices meet [lo, hi].
    std::vector<uint8_t> meets(3 * g, 0);
    for (size_t d = 0; d < 3; ++d)
      for (size_t i = 0; i < g; ++i) {
        const float lo = -bound + static_cast<float>(i) * h, hi = lo + h;
        meets[d * g + i] = hi >= support[d] && lo <= support[3 + d];
      }
    for (size_t c = 0; c < occupied.size(); ++c)
      if (!(meets[c % g] && meets[g + (c / g) % g] && meets[2 * g + c / (g * g)])) occupied[c] = 0;
  }
  generation = next_generation();
}

double OccupancyGrid::occupied_fraction() const {
  size_t n = 0;
  for (uint8_t o : occupied) n += o;
  return occupied.empty() ? 1.0 : static_cast<double>(n) / static_cast<double>(occupied.size());
}

std::string occupancy_array_name(int k) { return "occupancy." + std::to_string(k); }

std::vector<float> empty_raw_fill(size_t channels) {
  std::vector<float> f(channels, 0.0f);
  // render.hpp's raw layout: sigma at 3, blend at 4; ReLU(-1e4 + noise) = 0, sigmoid(-1e4) = 0.
  if (channels > 3) f[3] = -1e4f;
  if (channels > 4) f[4] = -1e4f;
  return f;
}

}  // namespace nova

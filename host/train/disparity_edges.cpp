#include "nova/train/disparity_edges.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "train/square_min.hpp"

namespace nova {
namespace {

double median(std::vector<float>& v) {
  const size_t h = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(h), v.end());
  double m = v[h];
  if (v.size() % 2 == 0) m = 0.5 * (m + *std::max_element(v.begin(), v.begin() + static_cast<long>(h)));
  return m;
}

}  // namespace

std::optional<double> silhouette_step_share(const Scene& scene) {
  std::vector<float> shares;
  for (const Frame& f : scene.frames) {
    const ImageF& d = f.disparity;
    if (d.data.empty()) continue;
    const size_t w = static_cast<size_t>(d.width), h = static_cast<size_t>(d.height);
    for (size_t k = 1; k < f.masks.size(); ++k) {
      const Image8& mask = f.masks[k];
      if (static_cast<size_t>(mask.width) != w || static_cast<size_t>(mask.height) != h) continue;
      std::vector<float> m(w * h);
      for (size_t i = 0; i < m.size(); ++i) m[i] = mask.data[i] >= 128 ? 1.0f : 0.0f;
      // 1 where every pixel within the reach (a square) is inside the mask; outer: where any is.
      const std::vector<float> inner1 = detail::square_min(m, w, h, 1), inner2 = detail::square_min(m, w, h, 2);
      const std::vector<float> outer1 = detail::square_max(m, w, h, 1), outer2 = detail::square_max(m, w, h, 2),
                               outer4 = detail::square_max(m, w, h, 4);
      std::vector<float> rim, touching, interior, far;
      for (size_t i = 0; i < m.size(); ++i) {
        const float v = d.data[i];
        if (!std::isfinite(v)) continue;
        if (m[i] > 0 && inner1[i] == 0) rim.push_back(v);
        if (m[i] == 0 && outer1[i] > 0) touching.push_back(v);
        if (inner2[i] > 0) interior.push_back(v);
        if (outer2[i] == 0 && outer4[i] > 0) far.push_back(v);
      }
      if (interior.size() < 3 || rim.empty() || touching.empty() || far.empty()) continue;
      const double full = median(interior) - median(far);
      if (!(full > 0)) continue;
      shares.push_back(static_cast<float>((median(rim) - median(touching)) / full));
    }
  }
  if (shares.empty()) return std::nullopt;
  return median(shares);
}

}  // namespace nova

#include "nova/train/object_depth_rims.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace nova {

namespace {

// Running maximum over [i - r, i + r] of a row or column of n values `step` apart, in place.
void window_max(float* v, int n, int step, int r, std::vector<float>& line) {
  line.assign(static_cast<size_t>(n), 0.0f);
  for (int i = 0; i < n; ++i) line[static_cast<size_t>(i)] = v[static_cast<ptrdiff_t>(i) * step];
  for (int i = 0; i < n; ++i) {
    float m = -std::numeric_limits<float>::infinity();
    for (int j = std::max(0, i - r); j <= std::min(n - 1, i + r); ++j) m = std::max(m, line[static_cast<size_t>(j)]);
    v[static_cast<ptrdiff_t>(i) * step] = m;
  }
}

}  // namespace

int object_rim_radius(double width_fraction, int image_width) {
  if (!(width_fraction > 0.0)) return 0;
  return std::max(1, static_cast<int>(std::lround(width_fraction * image_width)));
}

ImageF object_rim_disparity(const Frame& frame, int radius) {
  ImageF out = frame.disparity;
  if (radius <= 0 || out.empty()) return out;
  const int W = out.width, H = out.height;
  const size_t n = static_cast<size_t>(W) * static_cast<size_t>(H);
  std::vector<float> spread(n), line;
  for (size_t k = 1; k < frame.masks.size(); ++k) {
    const Image8& m = frame.masks[k];
    if (m.width != W || m.height != H) continue;
    // Outside the mask -inf, so the separable square maximum only ever reads the mask's own.
    for (size_t i = 0; i < n; ++i)
      spread[i] = m.data[i] >= 128 ? frame.disparity.data[i] : -std::numeric_limits<float>::infinity();
    for (int y = 0; y < H; ++y) window_max(spread.data() + static_cast<size_t>(y) * W, W, 1, radius, line);
    for (int x = 0; x < W; ++x) window_max(spread.data() + x, H, W, radius, line);
    for (size_t i = 0; i < n; ++i)
      if (m.data[i] >= 128) out.data[i] = std::max(out.data[i], spread[i]);
  }
  return out;
}

}  // namespace nova

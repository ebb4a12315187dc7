#include "train/float_plane.hpp"

#include <algorithm>
#include <cmath>

namespace nova {

float FloatPlane::sample(double x, double y, int c) const {
  const int x0 = std::clamp(static_cast<int>(std::floor(x)), 0, std::max(width - 2, 0));
  const int y0 = std::clamp(static_cast<int>(std::floor(y)), 0, std::max(height - 2, 0));
  const int x1 = std::min(x0 + 1, width - 1), y1 = std::min(y0 + 1, height - 1);
  const double fx = x - x0, fy = y - y0;
  const double top = (1 - fx) * at(x0, y0, c) + fx * at(x1, y0, c);
  const double bottom = (1 - fx) * at(x0, y1, c) + fx * at(x1, y1, c);
  return static_cast<float>((1 - fy) * top + fy * bottom);
}

FloatPlane blurred_plane(const Image8& im, double sigma) {
  FloatPlane p{im.width, im.height, im.channels, std::vector<float>(im.data.size())};
  for (size_t i = 0; i < im.data.size(); ++i) p.data[i] = im.data[i] / 255.0f;
  if (sigma <= 0) return p;
  const int r = std::max(1, static_cast<int>(std::ceil(3 * sigma)));
  std::vector<double> k(static_cast<size_t>(2 * r + 1));
  double sum = 0;
  for (int i = -r; i <= r; ++i) sum += k[static_cast<size_t>(i + r)] = std::exp(-0.5 * i * i / (sigma * sigma));
  for (double& v : k) v /= sum;
  const int W = p.width, H = p.height, C = p.channels;
  auto pass = [&](const std::vector<float>& in, std::vector<float>& out, int dx, int dy) {
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        for (int c = 0; c < C; ++c) {
          double s = 0;
          for (int i = -r; i <= r; ++i) {
            const int xs = std::clamp(x + i * dx, 0, W - 1), ys = std::clamp(y + i * dy, 0, H - 1);
            s += k[static_cast<size_t>(i + r)] * in[(static_cast<size_t>(ys) * W + xs) * C + c];
          }
          out[(static_cast<size_t>(y) * W + x) * C + c] = static_cast<float>(s);
        }
  };
  std::vector<float> tmp(p.data.size());
  pass(p.data, tmp, 1, 0);
  pass(tmp, p.data, 0, 1);
  return p;
}

}  // namespace nova

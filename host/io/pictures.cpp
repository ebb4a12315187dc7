// Quantisation and depth colouring. Only the colormap needs OpenCV; the rest is plain loops so
// the numbers match the metrics' quantisation exactly.
#include "nova/io/pictures.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <string>

#include "io/image_checks.hpp"
#include "nova/metrics/image_metrics.hpp"
#include "nova/runtime/error.hpp"

namespace nova {
using detail::check_buffer;
using detail::num;
namespace {

Image8 quantize(const char* what, const std::vector<float>& v, int width, int height,
                int channels) {
  check_buffer(what, v.size(), width, height, channels);
  Image8 out(width, height, channels);
  for (size_t i = 0; i < v.size(); ++i) out.data[i] = quantize_unit(v[i]);
  return out;
}

}  // namespace

Image8 float_rgb_to_image(const std::vector<float>& rgb, int width, int height) {
  return quantize("float_rgb_to_image", rgb, width, height, 3);
}

Image8 float_to_gray(const std::vector<float>& v, int width, int height) {
  return quantize("float_to_gray", v, width, height, 1);
}

DepthRange robust_depth_range(const std::vector<float>& depth, double lower_percent,
                              double upper_percent) {
  if (!(lower_percent >= 0 && lower_percent <= upper_percent && upper_percent <= 100))
    throw Error("robust_depth_range: percentiles " + num(lower_percent) + ", " +
                num(upper_percent) + " must satisfy 0 <= lower <= upper <= 100");
  std::vector<float> f;
  f.reserve(depth.size());
  for (float d : depth)
    if (std::isfinite(d)) f.push_back(d);
  if (f.empty()) return {0.0f, 1.0f};
  std::sort(f.begin(), f.end());
  const auto at = [&](double percent) {
    const double pos = percent / 100.0 * double(f.size() - 1);
    const size_t i = std::min(size_t(pos), f.size() - 1);
    const size_t j = std::min(i + 1, f.size() - 1);
    return float(f[i] + (double(f[j]) - f[i]) * (pos - double(i)));
  };
  return {at(lower_percent), at(upper_percent)};
}

Image8 depth_to_color(const std::vector<float>& depth, int width, int height, float lo,
                      float hi) {
  check_buffer("depth_to_color", depth.size(), width, height, 1);
  if (!std::isfinite(lo) || !std::isfinite(hi) || lo > hi)
    throw Error("depth_to_color: range [" + num(lo) + ", " + num(hi) +
                "] must be finite with lo <= hi");
  // Index 255 is viridis' bright yellow: near maps there.
  cv::Mat index(height, width, CV_8UC1);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const float d = depth[size_t(y) * width + x];
      float t;  // 0 at lo (near), 1 at hi (far)
      if (hi > lo) t = float((double(d) - lo) / (double(hi) - lo));
      else t = d <= lo ? 0.0f : 1.0f;
      index.at<uint8_t>(y, x) = quantize_unit(1.0f - t);
    }
  cv::Mat bgr;
  cv::applyColorMap(index, bgr, cv::COLORMAP_VIRIDIS);
  Image8 out(width, height, 3);
  for (int y = 0; y < height; ++y) {
    const uint8_t* s = bgr.ptr<uint8_t>(y);
    for (int x = 0; x < width; ++x) {
      if (!std::isfinite(depth[size_t(y) * width + x])) continue;  // stays black
      out.at(x, y, 0) = s[3 * x + 2];
      out.at(x, y, 1) = s[3 * x + 1];
      out.at(x, y, 2) = s[3 * x + 0];
    }
  }
  return out;
}

}  // namespace nova

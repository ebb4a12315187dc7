#pragma once
// A frame as floats in [0, 1], blurred, with bilinear sampling: what the host-side fits that
// compare frames (motion_alignment.cpp, disparity_fit.cpp) sample.
#include <vector>

#include "nova/model/scene.hpp"

namespace nova {

struct FloatPlane {
  int width = 0, height = 0, channels = 0;
  std::vector<float> data;
  float at(int x, int y, int c) const { return data[(static_cast<size_t>(y) * width + x) * channels + c]; }
  // Bilinear; (x, y) must lie in [0, W - 1] x [0, H - 1].
  float sample(double x, double y, int c) const;
  bool contains(double x, double y) const { return x >= 0 && y >= 0 && x <= width - 1 && y <= height - 1; }
};

// An 8-bit image scaled to [0, 1] and blurred by a separable Gaussian of `sigma` pixels
// (<= 0: not blurred).
FloatPlane blurred_plane(const Image8& image, double sigma);

}  // namespace nova

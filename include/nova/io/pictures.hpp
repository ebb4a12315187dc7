#pragma once
// Rendered buffers as pictures: RGB and grey quantisation, depth maps in colour. Implemented in
// nova_io (OpenCV); no OpenCV types here. Images are RGB-interleaved Image8 as everywhere in
// nova (include/nova/model/scene.hpp); PNG output is nova::write_png (include/nova/io/image_io.hpp).
#include <vector>

#include "nova/model/scene.hpp"

namespace nova {

// [height * width * 3] values in [0, 1] -> RGB, with nova::quantize_unit (clamped, rounded
// half up, NaN -> 0): the quantisation the metrics assume.
Image8 float_rgb_to_image(const std::vector<float>& rgb, int width, int height);
// [height * width] values in [0, 1] (masks, opacity, blending weights) -> one 8-bit channel,
// with the same quantisation.
Image8 float_to_gray(const std::vector<float>& v, int width, int height);

struct DepthRange {
  float lo = 0, hi = 1;
};
// The 1st and 99th percentiles (by default) of the finite depths, linearly interpolated as
// numpy.percentile does, so a few stray samples do not wash out the map. {0, 1} when no
// value is finite. lo == hi when the depth is constant.
DepthRange robust_depth_range(const std::vector<float>& depth, double lower_percent = 1.0,
                              double upper_percent = 99.0);

// [height * width] depths -> RGB through the viridis colormap, near (lo) bright yellow, far
// (hi) dark purple. Viridis rather than turbo because its luminance rises monotonically (up
// to the 8-bit rounding of OpenCV's table), so brightness alone reads as nearness. Depths
// outside [lo, hi] are clamped; NaN and +-inf are black. lo == hi splits at lo (<= lo
// brightest, > lo darkest). Throws nova::Error when lo or hi is not finite or lo > hi.
Image8 depth_to_color(const std::vector<float>& depth, int width, int height, float lo,
                      float hi);

}  // namespace nova

#pragma once
// Reading and writing 8-bit images (PNG, and JPEG for reading), with errors that name the
// file and the problem. Implemented with OpenCV in nova_io; no OpenCV types here.
#include <string>

#include "nova/model/scene.hpp"

namespace nova {

// RGB (3 channels). Grey images are expanded; an alpha channel is composited over white when
// `white_background` (Blender scenes), else dropped. 16-bit images are scaled to 8 bits.
// `had_alpha`, when given, says whether the file had an alpha channel.
Image8 read_rgb(const std::string& path, bool white_background = false, bool* had_alpha = nullptr);
// The alpha channel (255 when the image has none).
Image8 read_alpha(const std::string& path);
// Single channel: any non-zero value (after converting colour to grey) becomes 255, as the
// reference code's `mask > 1e-3` does.
Image8 read_mask(const std::string& path);

// PNG with fixed settings, so equal images give equal bytes.
void write_png(const std::string& path, const Image8& image);

// Area downscaling (for a downscale factor) and nearest-neighbour resizing (for masks and
// disparity, as the reference code does).
Image8 resize_area(const Image8& image, int width, int height);
// `image` (read from `name`) downscaled by `factor` (area): Error naming the file when the
// factor leaves no pixel.
Image8 downscale_by(const Image8& image, int factor, const std::string& name);
Image8 resize_nearest(const Image8& image, int width, int height);
ImageF resize_nearest(const ImageF& image, int width, int height);

}  // namespace nova

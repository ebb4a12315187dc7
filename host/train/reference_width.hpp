// Pixel counts among the training's options and constants (blurs, reaches, gaps) are given
// for an image 160 px wide and scale with the image, so that a setting means the same width
// of the scene at any resolution.
#pragma once

namespace nova::detail {

inline constexpr double kReferenceWidth = 160.0;

// Pixels of an image `width` wide per pixel of the reference width.
inline double reference_scale(int width) { return width / kReferenceWidth; }

}  // namespace nova::detail

#pragma once
// Image quality metrics on 8-bit images, in plain C++ (no OpenCV), so the numbers a training
// run reports can be computed anywhere and compared with the papers' tables.
#include <cmath>
#include <cstdint>

#include "nova/model/scene.hpp"

namespace nova {

// The 8-bit quantisation of a rendered value in [0, 1]: clamp, then round half up
// (floor(v * 255 + 0.5), in double). NaN becomes 0. Rendered images go through this before
// PSNR/SSIM, so the metrics compare what would be written to disk.
inline uint8_t quantize_unit(float v) {
  if (!(v > 0.0f)) return 0;  // also NaN
  if (v >= 1.0f) return 255;
  return static_cast<uint8_t>(std::floor(double(v) * 255.0 + 0.5));
}

// Peak signal-to-noise ratio in dB, bit for bit what OpenCV 4.6's cv::PSNR(a, b) returns:
//   mse = sum over all pixels and channels of (a - b)^2 / (width * height * channels)
//   psnr = 20 log10(255 / (sqrt(mse) + DBL_EPSILON))
// The DBL_EPSILON keeps identical images finite: they give 20 log10(255 / 2^-52) = 361.20...
// (not +inf), as OpenCV does. Throws nova::Error when the sizes or channel counts differ or
// the images are empty.
double psnr(const Image8& a, const Image8& b);

// PSNR over the pixels a single-channel `region` of the same size selects (value >= 128, or
// < 128 with `inside` false), every channel of them, by the formula of psnr(). NaN when the
// region selects no pixel. Throws nova::Error on differing sizes, as psnr().
double region_psnr(const Image8& a, const Image8& b, const Image8& region, bool inside = true);

// Mean structural similarity (Wang et al. 2004) with the paper's constants: an 11 x 11
// Gaussian window with sigma 1.5 (normalised to sum 1), K1 = 0.01, K2 = 0.03, L = 255,
// population (not sample) variances and covariance, i.e.
//   mu = G * x,  var = G * x^2 - mu^2,  cov = G * (x y) - mu_x mu_y,
//   ssim = (2 mu_x mu_y + C1)(2 cov + C2) / ((mu_x^2 + mu_y^2 + C1)(var_x + var_y + C2)).
// The map is computed only where the window fits inside the image (no padding) and averaged;
// channels are computed independently and their means averaged. This is exactly
// skimage.metrics.structural_similarity(a, b, gaussian_weights=True, sigma=1.5,
// use_sample_covariance=False, data_range=255, channel_axis=-1), whose result is cropped
// to the same valid region, and the MATLAB ssim_index.m of the paper (filter2 'valid').
// Throws nova::Error when the sizes or channel counts differ or an image is smaller than the
// window (11 x 11).
double ssim(const Image8& a, const Image8& b);

}  // namespace nova

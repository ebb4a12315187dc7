// PSNR and SSIM without OpenCV. PSNR follows OpenCV's formula step by step (same operations
// in the same order) so the two agree to the last bit; SSIM filters separably in double.
#include "nova/metrics/image_metrics.hpp"

#include <cfloat>
#include <cmath>
#include <string>
#include <vector>

#include "nova/runtime/error.hpp"

namespace nova {
namespace {

std::string describe(const Image8& im) {
  return std::to_string(im.width) + "x" + std::to_string(im.height) + "x" +
         std::to_string(im.channels);
}

void check_same_shape(const Image8& a, const Image8& b, const char* metric) {
  if (a.width != b.width || a.height != b.height || a.channels != b.channels)
    throw Error(std::string(metric) + ": images differ in size (first " + describe(a) +
                ", second " + describe(b) + ", width x height x channels)");
  if (a.empty())
    throw Error(std::string(metric) + ": images are empty (" + describe(a) + ")");
  if (a.data.size() != size_t(a.width) * a.height * a.channels ||
      b.data.size() != a.data.size())
    throw Error(std::string(metric) + ": pixel buffer does not match " + describe(a));
}

constexpr int kRadius = 5;  // 11 taps: skimage's int(3.5 * 1.5 + 0.5) = 5 either side
constexpr double kSigma = 1.5;

std::vector<double> gaussian_taps() {
  std::vector<double> w(2 * kRadius + 1);
  double sum = 0;
  for (int i = -kRadius; i <= kRadius; ++i)
    sum += w[i + kRadius] = std::exp(-0.5 * i * i / (kSigma * kSigma));
  for (double& v : w) v /= sum;
  return w;
}

// Valid-region separable filter: (w x h) -> (w - 10) x (h - 10).
std::vector<double> filter_valid(const std::vector<double>& src, int w, int h,
                                 const std::vector<double>& taps) {
  const int ow = w - 2 * kRadius, oh = h - 2 * kRadius;
  std::vector<double> rows(size_t(h) * ow);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < ow; ++x) {
      double s = 0;
      for (int k = 0; k <= 2 * kRadius; ++k) s += taps[k] * src[size_t(y) * w + x + k];
      rows[size_t(y) * ow + x] = s;
    }
  std::vector<double> out(size_t(oh) * ow);
  for (int y = 0; y < oh; ++y)
    for (int x = 0; x < ow; ++x) {
      double s = 0;
      for (int k = 0; k <= 2 * kRadius; ++k) s += taps[k] * rows[size_t(y + k) * ow + x];
      out[size_t(y) * ow + x] = s;
    }
  return out;
}

// OpenCV's PSNR of a sum of squared 8-bit differences over `count` values.
double psnr_of_sse(uint64_t sse, uint64_t count) {
  const double diff = std::sqrt(double(sse) / double(count));
  return 20 * std::log10(255.0 / (diff + DBL_EPSILON));
}

}  // namespace

double psnr(const Image8& a, const Image8& b) {
  check_same_shape(a, b, "psnr");
  // Integer sum of squares, as cv::norm(NORM_L2SQR) accumulates 8-bit differences exactly.
  uint64_t sse = 0;
  for (size_t i = 0; i < a.data.size(); ++i) {
    const int d = int(a.data[i]) - int(b.data[i]);
    sse += uint64_t(d * d);
  }
  return psnr_of_sse(sse, a.data.size());
}

double region_psnr(const Image8& a, const Image8& b, const Image8& region, bool inside) {
  check_same_shape(a, b, "region_psnr");
  if (region.width != a.width || region.height != a.height || region.channels != 1 ||
      region.data.size() != size_t(a.width) * a.height)
    throw Error("region_psnr: region " + describe(region) + " is not a one-channel " +
                std::to_string(a.width) + "x" + std::to_string(a.height) + " mask");
  uint64_t sse = 0, count = 0;
  const size_t c = size_t(a.channels);
  for (size_t p = 0; p < region.data.size(); ++p) {
    if ((region.data[p] >= 128) != inside) continue;
    for (size_t k = p * c; k < (p + 1) * c; ++k) {
      const int d = int(a.data[k]) - int(b.data[k]);
      sse += uint64_t(d * d);
    }
    count += c;
  }
  return count == 0 ? std::nan("") : psnr_of_sse(sse, count);
}

double ssim(const Image8& a, const Image8& b) {
  check_same_shape(a, b, "ssim");
  if (a.width < 2 * kRadius + 1 || a.height < 2 * kRadius + 1)
    throw Error("ssim: images of " + describe(a) + " are smaller than the 11x11 window");
  const int w = a.width, h = a.height, nc = a.channels;
  const size_t n = size_t(w) * h;
  const double c1 = (0.01 * 255) * (0.01 * 255), c2 = (0.03 * 255) * (0.03 * 255);
  const auto taps = gaussian_taps();

  double total = 0;
  std::vector<double> x(n), y(n), xx(n), yy(n), xy(n);
  for (int c = 0; c < nc; ++c) {
    for (size_t i = 0; i < n; ++i) {
      x[i] = a.data[i * nc + c];
      y[i] = b.data[i * nc + c];
      xx[i] = x[i] * x[i];
      yy[i] = y[i] * y[i];
      xy[i] = x[i] * y[i];
    }
    const auto mx = filter_valid(x, w, h, taps), my = filter_valid(y, w, h, taps);
    const auto sxx = filter_valid(xx, w, h, taps), syy = filter_valid(yy, w, h, taps),
               sxy = filter_valid(xy, w, h, taps);
    double sum = 0;
    for (size_t i = 0; i < mx.size(); ++i) {
      const double vx = sxx[i] - mx[i] * mx[i], vy = syy[i] - my[i] * my[i];
      const double cov = sxy[i] - mx[i] * my[i];
      sum += ((2 * mx[i] * my[i] + c1) * (2 * cov + c2)) /
             ((mx[i] * mx[i] + my[i] * my[i] + c1) * (vx + vy + c2));
    }
    total += sum / double(mx.size());
  }
  return total / nc;
}

}  // namespace nova

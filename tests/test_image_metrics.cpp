// PSNR against OpenCV itself, SSIM against a direct float64 windowed-sum reference written
// here from the paper's definition (no separable filtering, no shared code).
#include <boost/test/unit_test.hpp>
#include <cmath>
#include <opencv2/core.hpp>
#include <random>

#include "nova/metrics/image_metrics.hpp"
#include "scene_test_util.hpp"

using namespace nova;
using namespace nova::test;

namespace {

Image8 random_image(int w, int h, int c, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> u(0, 255);
  Image8 im(w, h, c);
  for (auto& v : im.data) v = uint8_t(u(rng));
  return im;
}

// A smooth image plus clamped Gaussian noise of standard deviation `sigma`.
Image8 noisy(const Image8& base, double sigma, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  Image8 out = base;
  for (auto& v : out.data) v = uint8_t(std::clamp(std::lround(v + sigma * n(rng)), 0L, 255L));
  return out;
}

Image8 smooth_image(int w, int h, int c) {
  Image8 im(w, h, c);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < c; ++k)
        im.at(x, y, k) = uint8_t(127.5 + 100 * std::sin(0.21 * x + 0.5 * k) * std::cos(0.13 * y));
  return im;
}

double cv_psnr(const Image8& a, const Image8& b) {
  const cv::Mat ma(a.height, a.width, CV_8UC(a.channels), const_cast<uint8_t*>(a.data.data()));
  const cv::Mat mb(b.height, b.width, CV_8UC(b.channels), const_cast<uint8_t*>(b.data.data()));
  return cv::PSNR(ma, mb);
}

// The definition, term by term: the 11 x 11 window as exp(-(dx^2 + dy^2) / (2 sigma^2))
// normalised over the 2D window, every statistic a direct weighted sum over that window.
double reference_ssim(const Image8& a, const Image8& b) {
  double g[11][11], gsum = 0;
  for (int i = 0; i < 11; ++i)
    for (int j = 0; j < 11; ++j)
      gsum += g[i][j] = std::exp(-((i - 5) * (i - 5) + (j - 5) * (j - 5)) / 4.5);
  const double c1 = 6.5025, c2 = 58.5225;  // (0.01 * 255)^2, (0.03 * 255)^2
  double total = 0;
  for (int c = 0; c < a.channels; ++c) {
    double sum = 0;
    int count = 0;
    for (int y = 5; y + 5 < a.height; ++y)
      for (int x = 5; x + 5 < a.width; ++x) {
        double mx = 0, my = 0;
        for (int i = 0; i < 11; ++i)
          for (int j = 0; j < 11; ++j) {
            const double w = g[i][j] / gsum;
            mx += w * a.at(x + j - 5, y + i - 5, c);
            my += w * b.at(x + j - 5, y + i - 5, c);
          }
        double vx = 0, vy = 0, cov = 0;  // centred sums: no cancellation in the reference
        for (int i = 0; i < 11; ++i)
          for (int j = 0; j < 11; ++j) {
            const double w = g[i][j] / gsum;
            const double dx = a.at(x + j - 5, y + i - 5, c) - mx;
            const double dy = b.at(x + j - 5, y + i - 5, c) - my;
            vx += w * dx * dx;
            vy += w * dy * dy;
            cov += w * dx * dy;
          }
        sum += (2 * mx * my + c1) * (2 * cov + c2) / ((mx * mx + my * my + c1) * (vx + vy + c2));
        ++count;
      }
    total += sum / count;
  }
  return total / a.channels;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(image_metrics)

BOOST_AUTO_TEST_CASE(psnr_matches_opencv) {
  // Same operations as cv::PSNR, so 1e-9 dB leaves room only for a different formula.
  for (unsigned seed = 1; seed <= 4; ++seed) {
    const Image8 a = random_image(37, 23, 3, seed), b = random_image(37, 23, 3, seed + 100);
    BOOST_TEST(std::abs(psnr(a, b) - cv_psnr(a, b)) <= 1e-9);
  }
  const Image8 g1 = random_image(16, 9, 1, 5), g2 = random_image(16, 9, 1, 6);
  BOOST_TEST(std::abs(psnr(g1, g2) - cv_psnr(g1, g2)) <= 1e-9);
  // Nearly identical: one value off by one in 37 x 23 x 3.
  const Image8 a = random_image(37, 23, 3, 9);
  Image8 b = a;
  b.data[100] = uint8_t(b.data[100] ^ 1);
  BOOST_TEST(std::abs(psnr(a, b) - cv_psnr(a, b)) <= 1e-9);
  BOOST_TEST(psnr(a, b) > 70.0);
}

BOOST_AUTO_TEST_CASE(psnr_of_identical_images_is_opencvs_361) {
  const Image8 a = random_image(8, 8, 3, 3);
  BOOST_TEST(psnr(a, a) == cv_psnr(a, a));
  BOOST_TEST(std::abs(psnr(a, a) - 361.20199909921956) <= 1e-9);  // 20 log10(255 / 2^-52)
}

// The region's PSNR is OpenCV's PSNR of the selected pixels alone, gathered into images of
// their own (every channel of a selected pixel, none of the others).
BOOST_AUTO_TEST_CASE(region_psnr_is_psnr_of_the_selected_pixels) {
  const Image8 a = random_image(29, 17, 3, 31), b = noisy(a, 12.0, 32);
  Image8 region(29, 17, 1);
  for (int y = 0; y < 17; ++y)
    for (int x = 0; x < 29; ++x) region.at(x, y) = uint8_t((x * x + 3 * y) % 7 < 3 ? 200 : 40);
  region.at(0, 0) = 128, region.at(1, 0) = 127;  // the threshold: 128 is inside, 127 outside
  for (const bool inside : {true, false}) {
    std::vector<uint8_t> sa, sb;
    for (size_t p = 0; p < region.data.size(); ++p)
      if ((region.data[p] >= 128) == inside)
        for (size_t k = 0; k < 3; ++k) sa.push_back(a.data[p * 3 + k]), sb.push_back(b.data[p * 3 + k]);
    Image8 ga(int(sa.size() / 3), 1, 3), gb = ga;
    ga.data = sa, gb.data = sb;
    BOOST_TEST(std::abs(region_psnr(a, b, region, inside) - cv_psnr(ga, gb)) <= 1e-9, "inside " << inside);
  }
  const Image8 all(29, 17, 1, 255), none(29, 17, 1, 0);
  BOOST_TEST(region_psnr(a, b, all) == psnr(a, b));
  BOOST_TEST(std::isnan(region_psnr(a, b, none)));
  BOOST_TEST(region_psnr(a, b, none, false) == psnr(a, b));
  expect_error([&] { region_psnr(a, b, Image8(29, 16, 1)); }, {"region_psnr", "29x16x1", "29x17"});
  expect_error([&] { region_psnr(a, b, a); }, {"region_psnr", "29x17x3", "one-channel"});
}

BOOST_AUTO_TEST_CASE(ssim_of_identical_images_is_one) {
  const Image8 a = random_image(20, 15, 3, 4);
  BOOST_TEST(std::abs(ssim(a, a) - 1.0) <= 1e-12);
}

BOOST_AUTO_TEST_CASE(ssim_matches_direct_reference) {
  // Both in float64; the separable E[x^2] - E[x]^2 form loses at most ~1e-11 relative to the
  // centred sums at 8-bit magnitudes, so 1e-6 is generous.
  const Image8 base = smooth_image(31, 24, 3);
  for (double sigma : {3.0, 20.0, 80.0}) {
    const Image8 b = noisy(base, sigma, 11);
    BOOST_TEST(std::abs(ssim(base, b) - reference_ssim(base, b)) <= 1e-6, "sigma " << sigma);
  }
  const Image8 r1 = random_image(13, 17, 1, 21), r2 = random_image(13, 17, 1, 22);
  BOOST_TEST(std::abs(ssim(r1, r2) - reference_ssim(r1, r2)) <= 1e-6);
}

BOOST_AUTO_TEST_CASE(ssim_falls_as_noise_grows) {
  const Image8 base = smooth_image(48, 40, 3);
  double last = 1.0;
  for (double sigma : {1.0, 4.0, 10.0, 25.0, 60.0}) {
    const double s = ssim(base, noisy(base, sigma, 5));
    BOOST_TEST(s < last, "sigma " << sigma << ": " << s << " after " << last);
    last = s;
  }
  BOOST_TEST(last < 0.5);
}

BOOST_AUTO_TEST_CASE(mismatched_images_are_errors) {
  const Image8 a(20, 20, 3), b(20, 19, 3), c(20, 20, 1), tiny(10, 20, 3);
  expect_error([&] { psnr(a, b); }, {"psnr", "20x20x3", "20x19x3"});
  expect_error([&] { ssim(a, c); }, {"ssim", "20x20x3", "20x20x1"});
  expect_error([&] { ssim(tiny, tiny); }, {"ssim", "10x20x3", "11x11"});
  expect_error([&] { psnr(Image8(), Image8()); }, {"psnr", "empty"});
}

BOOST_AUTO_TEST_CASE(quantisation_rounds_half_up_and_clamps) {
  BOOST_TEST(quantize_unit(0.0f) == 0);
  BOOST_TEST(quantize_unit(1.0f) == 255);
  BOOST_TEST(quantize_unit(-3.0f) == 0);
  BOOST_TEST(quantize_unit(7.0f) == 255);
  BOOST_TEST(quantize_unit(std::nanf("")) == 0);
  BOOST_TEST(quantize_unit(0.5f) == 128);  // 127.5 rounds up
  for (int k = 0; k <= 255; ++k) BOOST_TEST(quantize_unit(float(k) / 255.0f) == k);
}

BOOST_AUTO_TEST_SUITE_END()

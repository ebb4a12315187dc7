// Quantisation, the depth colormap and MP4 output. Debian 12's OpenCV 4.6 has
// the FFmpeg backend with an 'mp4v' encoder, so videos are written and read back here; the
// "no encoder" error is reached through a container FFmpeg does not know. A build without
// videoio refuses every video with an error that says so.
#include <boost/test/unit_test.hpp>
#include <cmath>
#include <limits>
#if NOVA_HAVE_VIDEOIO
#include <opencv2/videoio.hpp>
#endif

#include "nova/metrics/image_metrics.hpp"
#include "nova/io/charts.hpp"
#include "nova/io/pictures.hpp"
#include "nova/io/video.hpp"
#include "scene_test_util.hpp"

using namespace nova;
using namespace nova::test;

namespace {

double luminance(const Image8& im, int x, int y) {
  return 0.2126 * im.at(x, y, 0) + 0.7152 * im.at(x, y, 1) + 0.0722 * im.at(x, y, 2);
}

std::vector<std::string> folder_names(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

// A frame whose colour changes with i, so that dropped or repeated frames would show.
Image8 test_frame(int w, int h, int i) {
  Image8 f(w, h, 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      f.at(x, y, 0) = uint8_t(20 * i);
      f.at(x, y, 1) = uint8_t(4 * x);
      f.at(x, y, 2) = uint8_t(200 - 10 * i);
    }
  return f;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(visualize)

BOOST_AUTO_TEST_CASE(quantisation_round_trip) {
  // Every 8-bit level survives level / 255 -> float -> 8 bits, in RGB and grey.
  std::vector<float> rgb(256 * 3), gray(256);
  for (int k = 0; k < 256; ++k) {
    gray[k] = float(k) / 255.0f;
    for (int c = 0; c < 3; ++c) rgb[3 * k + c] = float((k + 85 * c) % 256) / 255.0f;
  }
  const Image8 im = float_rgb_to_image(rgb, 16, 16);
  BOOST_TEST(im.channels == 3);
  for (int k = 0; k < 256; ++k)
    for (int c = 0; c < 3; ++c) BOOST_TEST(im.data[3 * k + c] == (k + 85 * c) % 256);
  const Image8 g = float_to_gray(gray, 256, 1);
  BOOST_TEST(g.channels == 1);
  for (int k = 0; k < 256; ++k) BOOST_TEST(g.data[k] == k);
  // Out of range and NaN: clamped, NaN -> 0; the same function the metrics use.
  const Image8 e = float_to_gray({-0.5f, 1.5f, std::nanf(""), 0.2f}, 2, 2);
  BOOST_TEST((e.data == std::vector<uint8_t>{0, 255, 0, quantize_unit(0.2f)}));
  expect_error([] { float_rgb_to_image(std::vector<float>(10), 2, 2); },
               {"float_rgb_to_image", "10 values", "2x2", "12"});
}

BOOST_AUTO_TEST_CASE(depth_colormap_is_brighter_when_nearer) {
  // A ramp from near (1) to far (3): luminance must fall with depth. Viridis is monotone in
  // luminance, but OpenCV stores it as 8-bit RGB, which makes two neighbouring levels dip by
  // 0.2 (levels 94-95 and 145-146); so neighbours may rise by at most 0.5, and every 1/16 of
  // the range must fall strictly.
  const int n = 512;
  std::vector<float> depth(n);
  for (int i = 0; i < n; ++i) depth[i] = 1.0f + 2.0f * float(i) / (n - 1);
  const Image8 im = depth_to_color(depth, n, 1, 1.0f, 3.0f);
  BOOST_TEST(im.channels == 3);
  for (int i = 1; i < n; ++i)
    BOOST_TEST(luminance(im, i, 0) <= luminance(im, i - 1, 0) + 0.5, "at " << i);
  for (int i = n / 16; i < n; i += n / 16)
    BOOST_TEST(luminance(im, i, 0) < luminance(im, i - n / 16, 0), "at " << i);
  BOOST_TEST(luminance(im, 0, 0) > luminance(im, n - 1, 0) + 100);
  // Viridis' ends: yellow (R and G high, B low) near, dark purple far.
  BOOST_TEST(im.at(0, 0, 0) > 200);
  BOOST_TEST(im.at(0, 0, 2) < 80);
  BOOST_TEST(im.at(n - 1, 0, 2) > im.at(n - 1, 0, 1));
  // Outside the range clamps to the ends.
  const Image8 c = depth_to_color({0.0f, 1.0f, 3.0f, 9.0f}, 4, 1, 1.0f, 3.0f);
  for (int ch = 0; ch < 3; ++ch) {
    BOOST_TEST(c.at(0, 0, ch) == c.at(1, 0, ch));
    BOOST_TEST(c.at(2, 0, ch) == c.at(3, 0, ch));
  }
}

BOOST_AUTO_TEST_CASE(non_finite_depth_is_black) {
  const float inf = std::numeric_limits<float>::infinity();
  const Image8 im = depth_to_color({std::nanf(""), inf, -inf, 2.0f}, 2, 2, 1.0f, 3.0f);
  for (int i = 0; i < 3; ++i)
    for (int ch = 0; ch < 3; ++ch) BOOST_TEST(im.data[3 * i + ch] == 0);
  BOOST_TEST(luminance(im, 1, 1) > 0);
  expect_error([] { depth_to_color({1.0f}, 1, 1, 2.0f, 1.0f); }, {"depth_to_color", "lo <= hi"});
  expect_error([&] { depth_to_color({1.0f}, 1, 1, 0.0f, inf); }, {"depth_to_color", "finite"});
}

BOOST_AUTO_TEST_CASE(robust_range_ignores_outliers) {
  // 0..99 plus a far outlier and NaNs: numpy.percentile(0..99 + [1e6], [1, 99]) on the 101
  // finite values is [1.0, 99.0].
  std::vector<float> d;
  for (int i = 0; i < 100; ++i) d.push_back(float(i));
  d.push_back(1e6f);
  d.push_back(std::nanf(""));
  d.push_back(std::numeric_limits<float>::infinity());
  const DepthRange r = robust_depth_range(d);
  BOOST_TEST(r.lo == 1.0f);
  BOOST_TEST(r.hi == 99.0f);
  const DepthRange none = robust_depth_range({std::nanf("")});
  BOOST_TEST((none.lo == 0.0f && none.hi == 1.0f));
  const DepthRange flat = robust_depth_range({2.0f, 2.0f, 2.0f});
  BOOST_TEST((flat.lo == 2.0f && flat.hi == 2.0f));
  // A constant map is valid input: everything at lo is drawn as nearest.
  const Image8 im = depth_to_color({2.0f, 2.0f}, 2, 1, flat.lo, flat.hi);
  BOOST_TEST(luminance(im, 0, 0) > 150);
}

#if NOVA_HAVE_VIDEOIO
BOOST_AUTO_TEST_CASE(write_video_round_trip) {
  TempDir dir("video");
  const int n = 12, w = 64, h = 48;
  std::vector<Image8> frames;
  for (int i = 0; i < n; ++i) frames.push_back(test_frame(w, h, i));
  const std::string path = (dir / "out.mp4").string();
  write_video(frames, path, 10.0);
  BOOST_TEST((folder_names(dir.path()) == std::vector<std::string>{"out.mp4"}));

  cv::VideoCapture cap(path);
  BOOST_REQUIRE(cap.isOpened());
  int count = 0;
  cv::Mat f;
  while (cap.read(f)) {
    BOOST_TEST(f.cols == w);
    BOOST_TEST(f.rows == h);
    // Lossy codec: compare the mean colour (BGR) of the frame with what was written.
    const cv::Scalar mean = cv::mean(f);
    BOOST_TEST(std::abs(mean[2] - 20.0 * count) < 8.0, "frame " << count << " red " << mean[2]);
    BOOST_TEST(std::abs(mean[0] - (200.0 - 10.0 * count)) < 8.0, "frame " << count);
    ++count;
  }
  BOOST_TEST(count == n);

  // Grey frames are accepted too, and a second write replaces the file.
  std::vector<Image8> grey(3, Image8(w, h, 1, 128));
  write_video(grey, path, 5.0);
  cv::VideoCapture cap2(path);
  count = 0;
  while (cap2.read(f)) ++count;
  BOOST_TEST(count == 3);
  BOOST_TEST((folder_names(dir.path()) == std::vector<std::string>{"out.mp4"}));
}

BOOST_AUTO_TEST_CASE(write_video_errors_leave_nothing) {
  TempDir dir("video-err");
  const std::vector<Image8> frames(2, test_frame(32, 16, 1));
  // No encoder opens for a container FFmpeg cannot guess: the codec error, no partial file.
  expect_error([&] { write_video(frames, (dir / "out.nosuchcontainer").string(), 10.0); },
               {"out.nosuchcontainer", "mp4v", "avc1", "PNG frames are still written"});
  BOOST_TEST(folder_names(dir.path()).empty());
  expect_error([&] { write_video(frames, (dir / "missing" / "out.mp4").string(), 10.0); },
               {"out.mp4", "missing", "does not exist"});
  expect_error([&] { write_video({}, (dir / "a.mp4").string(), 10.0); }, {"a.mp4", "no frames"});
  const std::vector<Image8> mixed = {frames[0], test_frame(16, 16, 0)};
  expect_error([&] { write_video(mixed, (dir / "a.mp4").string(), 10.0); },
               {"a.mp4", "frame 1", "16x16x3", "32x16x3"});
  expect_error([&] { write_video(frames, (dir / "a.mp4").string(), 0.0); }, {"a.mp4", "positive"});
  BOOST_TEST(folder_names(dir.path()).empty());
}

#else
BOOST_AUTO_TEST_CASE(write_video_without_videoio_is_a_clear_error) {
  TempDir dir("video-none");
  BOOST_TEST(!video_supported());
  expect_error([&] { write_video({test_frame(32, 16, 1)}, (dir / "out.mp4").string(), 10.0); },
               {"out.mp4", "without OpenCV's videoio"});
  BOOST_TEST(folder_names(dir.path()).empty());
}
#endif

// Pixels of exactly this RGB colour.
long count_colour(const Image8& im, uint8_t r, uint8_t g, uint8_t b) {
  long n = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) n += im.at(x, y, 0) == r && im.at(x, y, 1) == g && im.at(x, y, 2) == b;
  return n;
}

BOOST_AUTO_TEST_CASE(bar_groups_scale_with_the_values) {
  // Group 0 is Tableau blue (31, 119, 180), group 1 orange (255, 127, 14); bars are filled
  // rectangles from 0, so their pixel counts are proportional to the values (same widths).
  const auto chart = [](double a, double b, double c) {
    return plot_bar_groups({{"dev", {{"s1", a}, {"s2", b}}}, {"real", {{"r1", c}}}}, "t", "PSNR");
  };
  const Image8 one = chart(10, 20, 20);
  BOOST_TEST(one.width == 1000);
  BOOST_TEST(one.height == 420);
  BOOST_TEST(one.channels == 3);
  const long blue = count_colour(one, 31, 119, 180), orange = count_colour(one, 255, 127, 14);
  BOOST_TEST(blue > 0);
  BOOST_TEST(orange > 0);
  // Without the 20 dB bar, blue covers a third of it (10 of 30), within the rounding of the
  // bar ends and the group's label underline (a few hundred pixels).
  const Image8 two = chart(10, std::numeric_limits<double>::quiet_NaN(), 20);  // the same scale
  const long blue_nan = count_colour(two, 31, 119, 180);
  BOOST_TEST(blue_nan < blue / 2);
  BOOST_TEST(blue_nan > blue / 5);
  // An empty chart still draws its frame.
  BOOST_TEST(plot_bar_groups({}, "empty", "PSNR").width == 1000);
}

BOOST_AUTO_TEST_CASE(scatter_draws_each_group) {
  const Image8 im =
      plot_scatter({{"dev", {{10, 20}, {30, 25}}, {"a", "b"}}, {"real", {{20, 18}, {NAN, 3}}, {}}}, "t", "s", "PSNR", 800, 400);
  BOOST_TEST(im.width == 800);
  BOOST_TEST(im.height == 400);
  BOOST_TEST(count_colour(im, 31, 119, 180) > 50);   // two points and a legend marker
  BOOST_TEST(count_colour(im, 255, 127, 14) > 25);
  BOOST_TEST(count_colour(im, 44, 160, 44) == 0);    // no third group
  BOOST_TEST(plot_scatter({}, "empty", "x", "y").width == 1000);
}

BOOST_AUTO_TEST_CASE(image_rows_keep_pixels) {
  Image8 a = test_frame(20, 10, 1), g(8, 12, 1);
  for (int y = 0; y < 12; ++y)
    for (int x = 0; x < 8; ++x) g.at(x, y) = uint8_t(10 * x + y);
  const Image8 row = image_row({a, g}, {}, 4);
  BOOST_TEST(row.width == 32);
  BOOST_TEST(row.height == 12);
  for (int y = 0; y < 10; ++y)
    for (int x = 0; x < 20; ++x)
      for (int c = 0; c < 3; ++c) BOOST_TEST(row.at(x, y, c) == a.at(x, y, c));
  for (int y = 0; y < 12; ++y)
    for (int x = 0; x < 8; ++x)
      for (int c = 0; c < 3; ++c) BOOST_TEST(row.at(24 + x, y, c) == g.at(x, y));
  BOOST_TEST(row.at(21, 0, 0) == 255);  // the gap is white
  const Image8 captioned = image_row({a, g}, {"render", ""}, 4);
  BOOST_TEST(captioned.height > 12);
  BOOST_TEST(captioned.at(0, captioned.height - 12 + 0, 0) == a.at(0, 0, 0));
  const Image8 stack = stack_images({a, g}, 2);
  BOOST_TEST(stack.width == 20);
  BOOST_TEST(stack.height == 24);
  BOOST_TEST(stack.at(3, 12 + 5, 1) == g.at(3, 5));
  BOOST_CHECK_THROW(image_row({}), Error);
  BOOST_CHECK_THROW(image_row({a, Image8()}), Error);
}

BOOST_AUTO_TEST_SUITE_END()

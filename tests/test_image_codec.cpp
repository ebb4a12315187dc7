// The two image codecs behind nova_io (io/image_codec.hpp): OpenCV's imgcodecs and stb_image.
// Each round-trips its own PNGs exactly; where both are built they decode the same PNG bytes
// to the same pixels in OpenCV's layout (BGR(A), grey + alpha as BGRA, 16 bits kept), and JPEG
// to within the decoders' IDCT and upsampling differences (bound below).
#include <boost/test/unit_test.hpp>
#include <cstdlib>
#include <opencv2/imgproc.hpp>
#if NOVA_HAVE_IMGCODECS
#include <opencv2/imgcodecs.hpp>
#endif

#include "io/image_codec.hpp"
#include "nova/io/image_io.hpp"
#include "scene_test_util.hpp"

using namespace nova;
using namespace nova::detail;
using namespace nova::test;

namespace {

std::vector<ImageCodec> built() {
  std::vector<ImageCodec> c;
  for (ImageCodec k : {ImageCodec::OpenCV, ImageCodec::Stb})
    if (image_codec_built(k)) c.push_back(k);
  return c;
}

// A smooth gradient with a sharp square: exercises every channel and the JPEG edge case.
cv::Mat test_image(int w, int h, int channels, int depth = CV_8U) {
  cv::Mat m(h, w, CV_MAKETYPE(depth, channels));
  const double top = depth == CV_16U ? 65535 : 255;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < channels; ++c) {
        double v = (x * (c + 1) * 7 + y * 13 + c * 40) % 256 / 255.0;
        if (x > w / 3 && x < w / 2 && y > h / 3 && y < h / 2) v = 1.0 - v;
        const int q = static_cast<int>(v * top + 0.5);
        if (depth == CV_16U) m.ptr<uint16_t>(y)[x * channels + c] = static_cast<uint16_t>(q);
        else m.ptr<uint8_t>(y)[x * channels + c] = static_cast<uint8_t>(q);
      }
  return m;
}

bool same(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

// Sets NOVA_IMAGE_CODEC for one scope.
struct CodecEnv {
  explicit CodecEnv(const char* v) { ::setenv("NOVA_IMAGE_CODEC", v, 1); }
  ~CodecEnv() { ::unsetenv("NOVA_IMAGE_CODEC"); }
};

}  // namespace

BOOST_AUTO_TEST_SUITE(image_codec)

BOOST_AUTO_TEST_CASE(each_codec_round_trips_its_png) {
  BOOST_TEST(!built().empty());
  for (ImageCodec c : built())
    for (int channels : {1, 3, 4}) {
      BOOST_TEST_CONTEXT(image_codec_name(c) << ", " << channels << " channel(s)") {
        const cv::Mat m = test_image(37, 23, channels);
        std::vector<unsigned char> bytes;
        BOOST_TEST_REQUIRE(encode_png(m, bytes, c));
        BOOST_TEST(bytes.size() > 8u);
        BOOST_TEST(same(decode_image(bytes, c), m));
      }
    }
}

BOOST_AUTO_TEST_CASE(codecs_agree_on_the_same_bytes,
                     *boost::unit_test::precondition([](auto) { return built().size() == 2; })) {
  for (ImageCodec writer : built())
    for (int channels : {1, 3, 4}) {
      std::vector<unsigned char> bytes;
      BOOST_TEST_REQUIRE(encode_png(test_image(40, 30, channels), bytes, writer));
      BOOST_TEST(same(decode_image(bytes, ImageCodec::OpenCV), decode_image(bytes, ImageCodec::Stb)),
                 image_codec_name(writer) << "'s PNG, " << channels << " channel(s)");
    }
#if NOVA_HAVE_IMGCODECS
  // 16 bits per channel (OpenCV writes them; stb reads them as 16 bits too).
  std::vector<unsigned char> wide;
  BOOST_TEST_REQUIRE(cv::imencode(".png", test_image(21, 17, 3, CV_16U), wide));
  const cv::Mat a = decode_image(wide, ImageCodec::OpenCV), b = decode_image(wide, ImageCodec::Stb);
  BOOST_TEST(a.depth() == CV_16U);
  BOOST_TEST(same(a, b));
  // Grey + alpha (written by stb: OpenCV writes no two-channel PNG), which OpenCV decodes to
  // BGRA: stb's two channels must become the same.
  cv::Mat ga(9, 11, CV_8UC2);
  for (int y = 0; y < ga.rows; ++y)
    for (int x = 0; x < ga.cols; ++x) ga.at<cv::Vec2b>(y, x) = cv::Vec2b(uint8_t(20 * x), uint8_t(25 * y));
  std::vector<unsigned char> ga_bytes;
  BOOST_TEST_REQUIRE(encode_png(ga, ga_bytes, ImageCodec::Stb));
  const cv::Mat o = decode_image(ga_bytes, ImageCodec::OpenCV), s = decode_image(ga_bytes, ImageCodec::Stb);
  BOOST_TEST(o.channels() == 4);
  BOOST_TEST(same(o, s));
  // JPEG: libjpeg-turbo and stb_image differ in their IDCT and chroma upsampling. Measured on
  // Debian 12 (libjpeg-turbo 2.1.5, quality 95): at most 3 levels apart, 0.10 on average. The
  // bound doubles both (another libjpeg may round differently) and stays far below a wrong
  // channel order or a shifted row, which move the mean by tens of levels on this image.
  std::vector<unsigned char> jpg;
  BOOST_TEST_REQUIRE(cv::imencode(".jpg", test_image(64, 48, 3), jpg, {cv::IMWRITE_JPEG_QUALITY, 95}));
  const cv::Mat jo = decode_image(jpg, ImageCodec::OpenCV), js = decode_image(jpg, ImageCodec::Stb);
  BOOST_TEST_REQUIRE(jo.size() == js.size());
  BOOST_TEST_REQUIRE(jo.type() == js.type());
  const double worst = cv::norm(jo, js, cv::NORM_INF), mean = cv::norm(jo, js, cv::NORM_L1) / jo.total() / 3;
  BOOST_TEST_MESSAGE("JPEG: max difference " << worst << ", mean " << mean);
  BOOST_TEST(worst <= 6.0, "JPEG max difference " << worst);
  BOOST_TEST(mean <= 0.5, "JPEG mean difference " << mean);
#endif
}

// image_io through the stb codec: the same pixels as the default codec, and the same errors.
BOOST_AUTO_TEST_CASE(image_io_through_stb,
                     *boost::unit_test::precondition([](auto) { return image_codec_built(ImageCodec::Stb); })) {
  TempDir dir("codec");
  Image8 img(19, 7, 3);
  for (size_t i = 0; i < img.data.size(); ++i) img.data[i] = static_cast<uint8_t>(i * 37 % 251);
  const std::string path = (dir / "a.png").string();
  write_png(path, img);  // the default codec
  Image8 back;
  {
    CodecEnv env("stb");
    BOOST_TEST((detail::image_codec() == ImageCodec::Stb));
    back = read_rgb(path);
    BOOST_TEST(back.data == img.data);
    write_png((dir / "b.png").string(), img);  // stb's encoder
    BOOST_TEST(read_rgb((dir / "b.png").string()).data == img.data);
    const Image8 mask = read_mask(path);
    BOOST_TEST(mask.channels == 1);
    std::ofstream((dir / "bad.jpg").string()) << "not an image";
    expect_error([&] { read_rgb((dir / "bad.jpg").string()); }, {"bad.jpg", "cannot decode"});
  }
  BOOST_TEST(read_rgb((dir / "b.png").string()).data == img.data);  // stb's PNG, default codec
}

BOOST_AUTO_TEST_CASE(bad_codec_choice_is_a_clear_error) {
  {
    CodecEnv env("tiff");
    expect_error([] { detail::image_codec(); }, {"NOVA_IMAGE_CODEC", "tiff", "opencv, stb"});
  }
  for (ImageCodec c : {ImageCodec::OpenCV, ImageCodec::Stb})
    if (!image_codec_built(c)) {
      CodecEnv env(image_codec_name(c));
      expect_error([] { detail::image_codec(); }, {"NOVA_IMAGE_CODEC", image_codec_name(c), "no"});
    }
}

BOOST_AUTO_TEST_SUITE_END()

// See image_codec.hpp. Decoding is lossless for PNG in both codecs (the same pixels); JPEG
// decoders differ in their IDCT and chroma upsampling by a few levels (tests/test_image_codec).
#include "io/image_codec.hpp"

#include <cstdlib>
#include <cstring>
#include <limits>

#include "nova/runtime/error.hpp"

#if NOVA_HAVE_IMGCODECS
#include <opencv2/imgcodecs.hpp>
#endif
#if NOVA_HAVE_STB
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STBI_ONLY_PNG
#define STBI_ONLY_JPEG
#define STBI_NO_STDIO
#define STBI_WRITE_NO_STDIO
#include <stb_image.h>
#include <stb_image_write.h>
#include <opencv2/imgproc.hpp>
#endif

namespace nova::detail {
namespace {

#if NOVA_HAVE_STB
cv::Mat stb_decode(const std::vector<unsigned char>& bytes) {
  if (bytes.size() > static_cast<size_t>(std::numeric_limits<int>::max())) return {};  // stb counts in int
  const auto* p = bytes.data();
  const int len = static_cast<int>(bytes.size());
  int w = 0, h = 0, n = 0;
  const bool wide = stbi_is_16_bit_from_memory(p, len);
  void* px = wide ? static_cast<void*>(stbi_load_16_from_memory(p, len, &w, &h, &n, 0))
                  : static_cast<void*>(stbi_load_from_memory(p, len, &w, &h, &n, 0));
  if (!px) return {};
  const int depth = wide ? CV_16U : CV_8U;
  cv::Mat m = cv::Mat(h, w, CV_MAKETYPE(depth, n), px).clone();
  stbi_image_free(px);
  // stb gives RGB(A) and grey + alpha as two channels; OpenCV BGR(A), grey + alpha as BGRA.
  if (n == 2) {
    std::vector<cv::Mat> ga;
    cv::split(m, ga);
    cv::merge(std::vector<cv::Mat>{ga[0], ga[0], ga[0], ga[1]}, m);
  }
  if (n == 3) cv::cvtColor(m, m, cv::COLOR_RGB2BGR);
  if (n == 4) cv::cvtColor(m, m, cv::COLOR_RGBA2BGRA);
  return m;
}

void append_bytes(void* ctx, void* data, int size) {
  auto* out = static_cast<std::vector<unsigned char>*>(ctx);
  const auto* d = static_cast<const unsigned char*>(data);
  out->insert(out->end(), d, d + size);
}

bool stb_encode_png(const cv::Mat& m, std::vector<unsigned char>& out) {
  if (m.depth() != CV_8U) return false;
  cv::Mat rgb;
  if (m.channels() == 3) cv::cvtColor(m, rgb, cv::COLOR_BGR2RGB);
  else if (m.channels() == 4) cv::cvtColor(m, rgb, cv::COLOR_BGRA2RGBA);
  else rgb = m.isContinuous() ? m : m.clone();
  // stb's level is a global: set once (thread-safe static initialisation), never raced on.
  static const bool level_set = (stbi_write_png_compression_level = 6, true);
  (void)level_set;
  out.clear();
  return stbi_write_png_to_func(append_bytes, &out, rgb.cols, rgb.rows, rgb.channels(), rgb.data,
                                static_cast<int>(rgb.step)) != 0;
}
#endif

}  // namespace

bool image_codec_built(ImageCodec c) {
  return c == ImageCodec::OpenCV ? NOVA_HAVE_IMGCODECS != 0 : NOVA_HAVE_STB != 0;
}

const char* image_codec_name(ImageCodec c) { return c == ImageCodec::OpenCV ? "opencv" : "stb"; }

ImageCodec image_codec() {
  const char* env = std::getenv("NOVA_IMAGE_CODEC");
  if (env && *env) {
    for (ImageCodec c : {ImageCodec::OpenCV, ImageCodec::Stb})
      if (std::strcmp(env, image_codec_name(c)) == 0) {
        if (!image_codec_built(c))
          throw Error(std::string("NOVA_IMAGE_CODEC=") + env + ": this build has no " + env +
                      " image codec (built: " + (NOVA_HAVE_IMGCODECS ? "opencv" : "stb") + ")");
        return c;
      }
    throw Error(std::string("NOVA_IMAGE_CODEC='") + env + "' is not one of opencv, stb");
  }
  return NOVA_HAVE_IMGCODECS ? ImageCodec::OpenCV : ImageCodec::Stb;
}

cv::Mat decode_image(const std::vector<unsigned char>& bytes, ImageCodec c) {
  if (!image_codec_built(c))
    throw Error(std::string("image codec ") + image_codec_name(c) + " is not in this build");
#if NOVA_HAVE_IMGCODECS
  if (c == ImageCodec::OpenCV) return cv::imdecode(bytes, cv::IMREAD_UNCHANGED);
#endif
#if NOVA_HAVE_STB
  if (c == ImageCodec::Stb) return stb_decode(bytes);
#endif
  return {};
}

bool encode_png(const cv::Mat& m, std::vector<unsigned char>& out, ImageCodec c) {
  if (!image_codec_built(c))
    throw Error(std::string("image codec ") + image_codec_name(c) + " is not in this build");
#if NOVA_HAVE_IMGCODECS
  if (c == ImageCodec::OpenCV)
    return cv::imencode(".png", m, out, {cv::IMWRITE_PNG_COMPRESSION, 6});
#endif
#if NOVA_HAVE_STB
  if (c == ImageCodec::Stb) return stb_encode_png(m, out);
#endif
  return false;
}

}  // namespace nova::detail

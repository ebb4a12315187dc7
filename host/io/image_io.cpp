// 8-bit image I/O over OpenCV (the codec: image_codec.hpp). Files are read into memory first
// so that "missing", "unreadable", "not a PNG" and "truncated" get distinct messages; a
// decoder alone reports all of them as an empty image (and libpng may decode a truncated file
// partially).
#include "nova/io/image_io.hpp"

#include <algorithm>
#include <cstring>
#include <fstream>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "io/image_codec.hpp"
#include "nova/runtime/error.hpp"

namespace nova {
namespace {

const unsigned char kPngMagic[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};

std::vector<unsigned char> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open image");
  std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)),
                                   std::istreambuf_iterator<char>());
  if (in.bad()) throw Error(path + ": read error");
  return bytes;
}

bool ends_with_ci(const std::string& s, const std::string& suffix) {
  if (s.size() < suffix.size()) return false;
  for (size_t i = 0; i < suffix.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(s[s.size() - suffix.size() + i])) != suffix[i])
      return false;
  return true;
}

cv::Mat decode(const std::string& path) {
  const auto bytes = read_bytes(path);
  if (bytes.empty()) throw Error(path + ": empty file");
  const bool png = bytes.size() >= 8 && std::memcmp(bytes.data(), kPngMagic, 8) == 0;
  if (ends_with_ci(path, ".png")) {
    if (!png) throw Error(path + ": not a PNG file (bad signature)");
    // A complete PNG ends with the IEND chunk: length 0, "IEND", CRC ae 42 60 82.
    static const unsigned char iend[12] = {0, 0, 0, 0, 'I', 'E', 'N', 'D', 0xae, 0x42, 0x60, 0x82};
    if (bytes.size() < 8 + 12 || std::memcmp(bytes.data() + bytes.size() - 12, iend, 12) != 0)
      throw Error(path + ": truncated PNG (no IEND chunk at the end)");
  }
  cv::Mat m = detail::decode_image(bytes, detail::image_codec());
  if (m.empty()) throw Error(path + ": cannot decode image (corrupt or unsupported format)");
  if (m.depth() == CV_16U) m.convertTo(m, CV_8U, 1.0 / 257.0);
  if (m.depth() != CV_8U) throw Error(path + ": unsupported pixel depth (need 8 or 16 bits)");
  return m;
}

Image8 from_mat(const cv::Mat& m) {
  Image8 out(m.cols, m.rows, m.channels());
  for (int y = 0; y < m.rows; ++y)
    std::memcpy(&out.at(0, y), m.ptr(y), size_t(m.cols) * m.channels());
  return out;
}

cv::Mat to_mat(const Image8& img) {
  const int type = CV_8UC(img.channels);
  return cv::Mat(img.height, img.width, type, const_cast<uint8_t*>(img.data.data())).clone();
}

}  // namespace

Image8 read_rgb(const std::string& path, bool white_background, bool* had_alpha) {
  cv::Mat m = decode(path);
  if (had_alpha) *had_alpha = m.channels() == 4;
  cv::Mat rgb;
  if (m.channels() == 1) {
    cv::cvtColor(m, rgb, cv::COLOR_GRAY2RGB);
  } else if (m.channels() == 3) {
    cv::cvtColor(m, rgb, cv::COLOR_BGR2RGB);
  } else if (m.channels() == 4) {
    if (white_background) {
      // rgb * a + (1 - a), as NeRF's white_bkgd does, rounded to 8 bits.
      rgb.create(m.rows, m.cols, CV_8UC3);
      for (int y = 0; y < m.rows; ++y) {
        const uint8_t* s = m.ptr(y);
        uint8_t* d = rgb.ptr(y);
        for (int x = 0; x < m.cols; ++x) {
          const int a = s[4 * x + 3];
          for (int c = 0; c < 3; ++c)
            d[3 * x + c] = static_cast<uint8_t>((s[4 * x + 2 - c] * a + 255 * (255 - a) + 127) / 255);
        }
      }
    } else {
      cv::cvtColor(m, rgb, cv::COLOR_BGRA2RGB);
    }
  } else {
    throw Error(path + ": unsupported channel count " + std::to_string(m.channels()));
  }
  return from_mat(rgb);
}

Image8 read_alpha(const std::string& path) {
  cv::Mat m = decode(path);
  if (m.channels() != 4) return Image8(m.cols, m.rows, 1, 255);
  cv::Mat a;
  cv::extractChannel(m, a, 3);
  return from_mat(a);
}

Image8 read_mask(const std::string& path) {
  cv::Mat m = decode(path);
  cv::Mat grey;
  if (m.channels() == 1)
    grey = m;
  else if (m.channels() == 3)
    cv::cvtColor(m, grey, cv::COLOR_BGR2GRAY);
  else
    cv::cvtColor(m, grey, cv::COLOR_BGRA2GRAY);
  Image8 out = from_mat(grey);
  for (auto& v : out.data) v = v ? 255 : 0;
  return out;
}

void write_png(const std::string& path, const Image8& image) {
  cv::Mat m = to_mat(image);
  if (image.channels == 3) cv::cvtColor(m, m, cv::COLOR_RGB2BGR);
  if (image.channels == 4) cv::cvtColor(m, m, cv::COLOR_RGBA2BGRA);
  std::vector<unsigned char> bytes;
  if (!detail::encode_png(m, bytes, detail::image_codec())) throw Error(path + ": PNG encoding failed");
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw Error(path + ": cannot create");
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!out) throw Error(path + ": write failed");
}

Image8 resize_area(const Image8& image, int width, int height) {
  if (image.width == width && image.height == height) return image;
  cv::Mat out;
  cv::resize(to_mat(image), out, cv::Size(width, height), 0, 0, cv::INTER_AREA);
  return from_mat(out);
}

Image8 downscale_by(const Image8& image, int factor, const std::string& name) {
  if (factor <= 1) return image;
  const int w = image.width / factor, h = image.height / factor;
  if (w < 1 || h < 1)
    throw Error(name + ": " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                " downscaled by --factor " + std::to_string(factor) + " leaves no pixels (at most --factor " +
                std::to_string(std::min(image.width, image.height)) + ")");
  return resize_area(image, w, h);
}

Image8 resize_nearest(const Image8& image, int width, int height) {
  if (image.width == width && image.height == height) return image;
  cv::Mat out;
  cv::resize(to_mat(image), out, cv::Size(width, height), 0, 0, cv::INTER_NEAREST);
  return from_mat(out);
}

ImageF resize_nearest(const ImageF& image, int width, int height) {
  if (image.width == width && image.height == height) return image;
  cv::Mat in(image.height, image.width, CV_32F, const_cast<float*>(image.data.data()));
  cv::Mat out;
  cv::resize(in, out, cv::Size(width, height), 0, 0, cv::INTER_NEAREST);
  ImageF r;
  r.width = width;
  r.height = height;
  r.data.assign(out.ptr<float>(0), out.ptr<float>(0) + size_t(width) * height);
  return r;
}

}  // namespace nova

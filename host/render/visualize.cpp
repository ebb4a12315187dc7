// Quantisation, depth colouring and MP4 output. Only the colormap and the video writer need
// OpenCV; the rest is plain loops so the numbers match the metrics' quantisation exactly.
#include "nova/visualize.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>
#include <string>

#include "nova/error.hpp"
#include "nova/image_metrics.hpp"

namespace nova {
namespace fs = std::filesystem;
namespace {

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

std::string dims(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

void check_buffer(const char* what, size_t size, int width, int height, int channels) {
  if (width <= 0 || height <= 0)
    throw Error(std::string(what) + ": image size " + dims(width, height) + " is not positive");
  const size_t want = size_t(width) * height * channels;
  if (size != want)
    throw Error(std::string(what) + ": buffer holds " + std::to_string(size) + " values, " +
                dims(width, height) + " x " + std::to_string(channels) + " needs " +
                std::to_string(want));
}

Image8 quantize(const char* what, const std::vector<float>& v, int width, int height,
                int channels) {
  check_buffer(what, v.size(), width, height, channels);
  Image8 out(width, height, channels);
  for (size_t i = 0; i < v.size(); ++i) out.data[i] = quantize_unit(v[i]);
  return out;
}

// Removes a temporary file on every exit path unless released.
class TempFile {
 public:
  explicit TempFile(fs::path p) : path_(std::move(p)) {}
  ~TempFile() {
    std::error_code ec;
    if (!path_.empty()) fs::remove(path_, ec);
  }
  void release() { path_.clear(); }

 private:
  fs::path path_;
};

}  // namespace

Image8 float_rgb_to_image(const std::vector<float>& rgb, int width, int height) {
  return quantize("float_rgb_to_image", rgb, width, height, 3);
}

Image8 float_to_gray(const std::vector<float>& v, int width, int height) {
  return quantize("float_to_gray", v, width, height, 1);
}

DepthRange robust_depth_range(const std::vector<float>& depth, double lower_percent,
                              double upper_percent) {
  if (!(lower_percent >= 0 && lower_percent <= upper_percent && upper_percent <= 100))
    throw Error("robust_depth_range: percentiles " + num(lower_percent) + ", " +
                num(upper_percent) + " must satisfy 0 <= lower <= upper <= 100");
  std::vector<float> f;
  f.reserve(depth.size());
  for (float d : depth)
    if (std::isfinite(d)) f.push_back(d);
  if (f.empty()) return {0.0f, 1.0f};
  std::sort(f.begin(), f.end());
  const auto at = [&](double percent) {
    const double pos = percent / 100.0 * double(f.size() - 1);
    const size_t i = std::min(size_t(pos), f.size() - 1);
    const size_t j = std::min(i + 1, f.size() - 1);
    return float(f[i] + (double(f[j]) - f[i]) * (pos - double(i)));
  };
  return {at(lower_percent), at(upper_percent)};
}

Image8 depth_to_color(const std::vector<float>& depth, int width, int height, float lo,
                      float hi) {
  check_buffer("depth_to_color", depth.size(), width, height, 1);
  if (!std::isfinite(lo) || !std::isfinite(hi) || lo > hi)
    throw Error("depth_to_color: range [" + num(lo) + ", " + num(hi) +
                "] must be finite with lo <= hi");
  // Index 255 is viridis' bright yellow: near maps there.
  cv::Mat index(height, width, CV_8UC1);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const float d = depth[size_t(y) * width + x];
      float t;  // 0 at lo (near), 1 at hi (far)
      if (hi > lo) t = float((double(d) - lo) / (double(hi) - lo));
      else t = d <= lo ? 0.0f : 1.0f;
      index.at<uint8_t>(y, x) = quantize_unit(1.0f - t);
    }
  cv::Mat bgr;
  cv::applyColorMap(index, bgr, cv::COLORMAP_VIRIDIS);
  Image8 out(width, height, 3);
  for (int y = 0; y < height; ++y) {
    const uint8_t* s = bgr.ptr<uint8_t>(y);
    for (int x = 0; x < width; ++x) {
      if (!std::isfinite(depth[size_t(y) * width + x])) continue;  // stays black
      out.at(x, y, 0) = s[3 * x + 2];
      out.at(x, y, 1) = s[3 * x + 1];
      out.at(x, y, 2) = s[3 * x + 0];
    }
  }
  return out;
}

void write_video(const std::vector<Image8>& frames, const std::string& path, double fps) {
  if (frames.empty()) throw Error(path + ": cannot write a video with no frames");
  if (!(std::isfinite(fps) && fps > 0))
    throw Error(path + ": video frame rate " + num(fps) + " must be positive");
  const Image8& first = frames[0];
  if (first.channels != 1 && first.channels != 3)
    throw Error(path + ": video frames need 1 or 3 channels, frame 0 has " +
                std::to_string(first.channels));
  for (size_t i = 0; i < frames.size(); ++i) {
    const Image8& f = frames[i];
    if (f.width != first.width || f.height != first.height || f.channels != first.channels)
      throw Error(path + ": video frame " + std::to_string(i) + " is " +
                  dims(f.width, f.height) + "x" + std::to_string(f.channels) + ", frame 0 is " +
                  dims(first.width, first.height) + "x" + std::to_string(first.channels));
    check_buffer(path.c_str(), f.data.size(), f.width, f.height, f.channels);
  }

  const fs::path target(path);
  const fs::path dir = target.parent_path().empty() ? fs::path(".") : target.parent_path();
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw Error(path + ": cannot write video: folder " + dir.string() + " does not exist");
  if (target.extension().empty())
    throw Error(path + ": video path needs an extension such as .mp4 (it picks the container)");
  // Same extension as the target: FFmpeg chooses the container from it.
  const fs::path tmp = dir / (target.stem().string() + ".tmp" + target.extension().string());
  TempFile guard(tmp);

  const cv::Size size(first.width, first.height);
  cv::VideoWriter writer;
  const char* codecs[] = {"mp4v", "avc1"};
  bool opened = false;
  for (const char* c : codecs) {
    const int fourcc = cv::VideoWriter::fourcc(c[0], c[1], c[2], c[3]);
    // FFmpeg explicitly: CAP_ANY would also try GStreamer and OpenCV's image-sequence
    // writer, which print exceptions for every path they cannot parse. Grey frames are
    // expanded to BGR below: every encoder takes colour input.
    if (writer.open(tmp.string(), cv::CAP_FFMPEG, fourcc, fps, size, true)) {
      opened = true;
      break;
    }
  }
  if (!opened)
    throw Error(path + ": cannot write video: OpenCV's FFmpeg backend opened no encoder "
                "(tried fourcc 'mp4v' and 'avc1'); the PNG frames are still written");

  cv::Mat bgr;
  for (const Image8& f : frames) {
    const cv::Mat m(f.height, f.width, CV_8UC(f.channels), const_cast<uint8_t*>(f.data.data()));
    cv::cvtColor(m, bgr, f.channels == 3 ? cv::COLOR_RGB2BGR : cv::COLOR_GRAY2BGR);
    writer.write(bgr);
  }
  writer.release();  // finalises the container (the MP4 index is written here)

  // VideoWriter::write reports nothing, so an empty result is the only failure we can see.
  if (!fs::is_regular_file(tmp, ec) || fs::file_size(tmp, ec) == 0 || ec)
    throw Error(path + ": video encoder produced no output");
  fs::rename(tmp, target, ec);
  if (ec) throw Error(path + ": cannot rename " + tmp.string() + " into place: " + ec.message());
  guard.release();
}

}  // namespace nova

// MP4 output through OpenCV's videoio (where it was built).
#include "nova/io/video.hpp"

#include <cmath>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <string>
#if NOVA_HAVE_VIDEOIO
#include <opencv2/videoio.hpp>
#endif

#include "io/image_checks.hpp"
#include "nova/runtime/error.hpp"

namespace nova {
namespace fs = std::filesystem;
using detail::check_buffer;
using detail::dims;
using detail::num;
namespace {

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

bool video_supported() { return NOVA_HAVE_VIDEOIO != 0; }

void write_video(const std::vector<Image8>& frames, const std::string& path, double fps) {
  if (!video_supported())
    throw Error(path + ": cannot write video: this nova was built without OpenCV's videoio "
                "(install libopencv-videoio-dev and rebuild)");
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

#if NOVA_HAVE_VIDEOIO
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
#endif
}

}  // namespace nova

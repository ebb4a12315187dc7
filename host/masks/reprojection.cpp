// Frames as float images, the geometry of a pair of cameras and the fitted depth (masks_steps.hpp).
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "masks/masks_steps.hpp"
#include "nova/runtime/error.hpp"

namespace nova::masks {

std::vector<FrameData> prepare_frames(const Scene& scene) {
  std::vector<FrameData> out;
  out.reserve(scene.frames.size());
  for (const Frame& f : scene.frames) {
    FrameData d;
    d.camera = f.camera;
    const cv::Mat rgb8(f.rgb.height, f.rgb.width, CV_8UC3, const_cast<uint8_t*>(f.rgb.data.data()));
    rgb8.convertTo(d.rgb, CV_32FC3, 1.0 / 255.0);
    const cv::Scalar mean = cv::mean(d.rgb);
    std::vector<cv::Mat> ch;
    cv::split(d.rgb, ch);
    for (int c = 0; c < 3; ++c) ch[size_t(c)] *= 0.5 / std::max(mean[c], 1e-3);
    cv::merge(ch, d.rgb);
    d.disp = cv::Mat(f.disparity.height, f.disparity.width, CV_32F,
                     const_cast<float*>(f.disparity.data.data())).clone();
    out.push_back(std::move(d));
  }
  return out;
}

PairGeometry pair_geometry(const Camera& a, const Camera& b) {
  PairGeometry g{};
  // M = Rb^T Ra, T = Rb^T (ta - tb); c2w rows hold [R | t].
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      double s = 0;
      for (int k = 0; k < 3; ++k) s += b.rotation(k, r) * a.rotation(k, c);
      g.m[r * 3 + c] = s;
    }
    double s = 0;
    for (int k = 0; k < 3; ++k) s += b.rotation(k, r) * (a.position(k) - b.position(k));
    g.t[r] = s;
  }
  g.fxa = a.fx, g.fya = a.fy, g.cxa = a.cx, g.cya = a.cy;
  g.fxb = b.fx, g.fyb = b.fy, g.cxb = b.cx, g.cyb = b.cy;
  return g;
}

bool sample_bilinear(const cv::Mat& image, double x, double y, float* out) {
  const int w = image.cols, h = image.rows, c = image.channels();
  if (!(x >= 0 && y >= 0 && x <= w - 1 && y <= h - 1)) return false;
  const int x0 = std::min(int(x), w - 2 < 0 ? 0 : w - 2), y0 = std::min(int(y), h - 2 < 0 ? 0 : h - 2);
  const int x1 = std::min(x0 + 1, w - 1), y1 = std::min(y0 + 1, h - 1);
  const float fx = float(x - x0), fy = float(y - y0);
  const float* r0 = image.ptr<float>(y0);
  const float* r1 = image.ptr<float>(y1);
  for (int k = 0; k < c; ++k) {
    const float top = r0[x0 * c + k] + fx * (r0[x1 * c + k] - r0[x0 * c + k]);
    const float bottom = r1[x0 * c + k] + fx * (r1[x1 * c + k] - r1[x0 * c + k]);
    out[k] = top + fy * (bottom - top);
  }
  return true;
}

void apply_depth(std::vector<FrameData>& frames, const DepthFit& fit) {
  for (size_t i = 0; i < frames.size(); ++i) {
    frames[i].disp.convertTo(frames[i].inv_depth, CV_32F, fit.scale[i], fit.shift[i]);
    cv::max(frames[i].inv_depth, 1e-4, frames[i].inv_depth);
  }
}

std::vector<int> neighbours(int i, int n, const std::vector<int>& offsets) {
  std::vector<int> out;
  for (int o : offsets)
    for (int j : {i - o, i + o})
      if (o > 0 && j >= 0 && j < n && std::find(out.begin(), out.end(), j) == out.end()) out.push_back(j);
  return out;
}

}  // namespace nova::masks

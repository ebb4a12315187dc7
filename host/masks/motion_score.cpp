// The motion score of a frame (masks_steps.hpp): how badly its pixels, placed at their depth,
// fail to match the neighbouring frames where those see them.
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "masks/masks_steps.hpp"

namespace nova::masks {

PixelScorer::PixelScorer(const std::vector<FrameData>& frames, int i, const MotionMaskOptions& options)
    : frame_(frames[size_t(i)]), options_(options) {
  for (int j : neighbours(i, int(frames.size()), options.offsets))
    views_.push_back({&frames[size_t(j)], pair_geometry(frame_.camera, frames[size_t(j)].camera)});
  // Inverse depths tried per pixel: the fitted one times 1 + r for r in [-range, range], so
  // that a disparity wrong by a few percent (a monocular network's) is not motion; the same
  // depth for every neighbour, which a moving point does not fit.
  const int steps = options.depth_search > 0 ? 2 * options.depth_search_steps + 1 : 1;
  for (int k = 0; k < steps; ++k)
    factors_.push_back(steps == 1 ? 1.0 : 1.0 + options.depth_search * (2.0 * k / (steps - 1) - 1.0));
  const int w = frame_.rgb.cols;
  radius_ = options.match_radius > 0 ? options.match_radius : std::max(1, int(std::lround(w / 240.0)));
}

double PixelScorer::operator()(int x, int y, double inv_depth) const {
  const int w = frame_.rgb.cols, h = frame_.rgb.rows, R = radius_;
  const cv::Vec3f src = frame_.rgb.at<cv::Vec3f>(y, x);
  per_.clear();
  for (const auto& [g_frame, g] : views_) {
    double bx, by, bw;
    if (!reproject(g, x, y, inv_depth, bx, by, bw)) continue;
    float wj;
    if (!sample_bilinear(g_frame->inv_depth, bx, by, &wj)) continue;
    // Something nearer stands there in the neighbour: it cannot see this point.
    if (wj > bw * (1 + options_.occlusion_margin)) continue;
    // Colour and depth over the (2R + 1)^2 pixels around the landing point: the best colour
    // match and the nearest surface, so that R pixels of misplacement are no motion.
    const int cx = int(std::lround(bx)), cy = int(std::lround(by));
    float colour = 1e9f, nearest = 0;
    for (int dy = -R; dy <= R; ++dy) {
      const int yy = std::clamp(cy + dy, 0, h - 1);
      const cv::Vec3f* row = g_frame->rgb.ptr<cv::Vec3f>(yy);
      const float* wrow = g_frame->inv_depth.ptr<float>(yy);
      for (int dx = -R; dx <= R; ++dx) {
        const int xx = std::clamp(cx + dx, 0, w - 1);
        const cv::Vec3f d = row[xx] - src;
        colour = std::min(colour, (std::abs(d[0]) + std::abs(d[1]) + std::abs(d[2])) / 3);
        nearest = std::max(nearest, wrow[xx]);
      }
    }
    // A static point cannot vanish: the neighbour seeing behind it is motion.
    const double behind = std::max(0.0, bw - nearest) / std::max(bw, 1e-9);
    per_.push_back(float(colour / options_.colour_scale + behind / options_.depth_scale));
  }
  if (per_.empty()) return -1;
  std::sort(per_.begin(), per_.end());
  const size_t half = (per_.size() + 1) / 2;
  double s = 0;
  for (size_t k = 0; k < half; ++k) s += per_[k];
  return s / double(half);
}

double PixelScorer::best(int x, int y) const {
  const double w = frame_.inv_depth.at<float>(y, x);
  double out = -1;
  for (double factor : factors_) {
    const double s = (*this)(x, y, w * factor);
    if (s >= 0 && (out < 0 || s < out)) out = s;
  }
  return out;
}

cv::Mat motion_score(const std::vector<FrameData>& frames, int i, const MotionMaskOptions& options) {
  const FrameData& f = frames[size_t(i)];
  const PixelScorer scorer(frames, i, options);
  cv::Mat score(f.rgb.rows, f.rgb.cols, CV_32F, cv::Scalar(0));
  for (int y = 0; y < score.rows; ++y) {
    float* out = score.ptr<float>(y);
    for (int x = 0; x < score.cols; ++x) out[x] = float(std::max(0.0, scorer.best(x, y)));
  }
  return score;
}

cv::Mat peel_background(const std::vector<FrameData>& frames, int i, const cv::Mat& region, const cv::Mat& raw_score,
                        double threshold, const MotionMaskOptions& options) {
  if (options.peel_radius <= 0 || cv::countNonZero(region) == 0) return region;
  const FrameData& f = frames[size_t(i)];
  const PixelScorer scorer(frames, i, options);
  const int r = std::max(1, int(std::lround(options.peel_radius * f.rgb.cols)));
  // The farthest surface outside the region within r pixels (a disc): the background a pixel
  // at the region's edge would be, were its disparity blurred towards the object's. A minimum
  // filter over the inverse depth with the region's pixels out of reach (+inf); +inf where no
  // outside pixel is that near.
  cv::Mat disc(2 * r + 1, 2 * r + 1, CV_8U, cv::Scalar(0));
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx)
      if (dx * dx + dy * dy <= r * r) disc.at<uint8_t>(dy + r, dx + r) = 1;
  cv::Mat outside = f.inv_depth.clone(), far;
  outside.setTo(std::numeric_limits<float>::infinity(), region);
  cv::erode(outside, far, disc);
  cv::Mat out = region.clone();
  for (int y = 0; y < region.rows; ++y)
    for (int x = 0; x < region.cols; ++x) {
      const float w_far = far.at<float>(y, x);
      if (!region.at<uint8_t>(y, x) || !(w_far < f.inv_depth.at<float>(y, x))) continue;
      // Only a pixel that is motion at its own depth can be a depth error: one that matched
      // there joined the region for other reasons (the score's blur, a filled hole).
      if (raw_score.at<float>(y, x) < threshold) continue;
      const double s = scorer(x, y, w_far);
      if (s >= 0 && s < threshold) out.at<uint8_t>(y, x) = 0;
    }
  return out;
}

}  // namespace nova::masks

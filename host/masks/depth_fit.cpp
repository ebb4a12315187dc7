// The disparity's scale and shift (masks_steps.hpp): the inverse depth w = a d + b under which
// textured pixels of each frame, reprojected into its neighbours, match in colour best.
// Searched as the inverse depths (u, v) at the disparity's 5th and 95th percentiles: a grid
// over [0, 2 / near]^2 on blurred images, then a pattern search, globally and per frame.
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "masks/masks_steps.hpp"
#include "nova/error.hpp"

namespace nova::masks {
namespace {

// A truncated colour error: moving pixels, occlusions and glare cost at most this much, so
// they cannot pull the fit.
constexpr double kTruncate = 0.15;

struct Sample {
  float x, y, d;
  float rgb[3];
};

struct Problem {
  std::vector<std::vector<Sample>> samples;  // per frame
  std::vector<std::vector<std::pair<int, PairGeometry>>> pairs;  // per frame: neighbour, geometry
  const std::vector<FrameData>* frames = nullptr;
  double d_lo = 0, d_hi = 1;
};

// Textured pixels on a grid: the half with the larger gradient, about `count` per frame.
std::vector<Sample> pick_samples(const FrameData& f, int count) {
  cv::Mat grey, gx, gy;
  cv::cvtColor(f.rgb_blur, grey, cv::COLOR_RGB2GRAY);
  cv::Sobel(grey, gx, CV_32F, 1, 0);
  cv::Sobel(grey, gy, CV_32F, 0, 1);
  const int stride = std::max(1, int(std::sqrt(double(f.rgb.cols) * f.rgb.rows / (2.0 * count))));
  std::vector<std::pair<float, Sample>> all;
  for (int y = 2; y < f.rgb.rows - 2; y += stride)
    for (int x = 2; x < f.rgb.cols - 2; x += stride) {
      Sample s{float(x), float(y), f.disp.at<float>(y, x), {}};
      const cv::Vec3f c = f.rgb_blur.at<cv::Vec3f>(y, x);
      for (int k = 0; k < 3; ++k) s.rgb[k] = c[k];
      const float g = gx.at<float>(y, x) * gx.at<float>(y, x) + gy.at<float>(y, x) * gy.at<float>(y, x);
      all.push_back({g, s});
    }
  std::sort(all.begin(), all.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  all.resize(std::min(all.size(), size_t(count)));
  std::vector<Sample> out;
  for (const auto& [g, s] : all) out.push_back(s);
  return out;
}

// Mean truncated colour error of frame i's samples (all frames when i < 0) at (u, v).
double cost(const Problem& p, int only, double u, double v) {
  const double a = (v - u) / (p.d_hi - p.d_lo), b = u - a * p.d_lo;
  double sum = 0;
  size_t count = 0, outside = 0;
  for (size_t i = 0; i < p.samples.size(); ++i) {
    if (only >= 0 && int(i) != only) continue;
    for (const auto& [j, g] : p.pairs[i]) {
      const cv::Mat& target = (*p.frames)[size_t(j)].rgb_blur;
      for (const Sample& s : p.samples[i]) {
        const double w = a * s.d + b;
        double bx, by, bw;
        float c[3];
        if (w <= 1e-6 || !reproject(g, s.x, s.y, w, bx, by, bw) || !sample_bilinear(target, bx, by, c)) {
          ++outside;
          continue;
        }
        const double e = (std::abs(c[0] - s.rgb[0]) + std::abs(c[1] - s.rgb[1]) + std::abs(c[2] - s.rgb[2])) / 3;
        sum += std::min(e, kTruncate);
        ++count;
      }
    }
  }
  // Depths that send most samples out of view (or behind the camera) explain nothing.
  if (count < outside) return kTruncate;
  return count ? sum / double(count) : kTruncate;
}

// Pattern search from (u, v) with a first step `step`, down to `step / 64`.
double refine(const Problem& p, int only, double& u, double& v, double step, double lo, double hi) {
  double best = cost(p, only, u, v);
  const double last = step / 64;
  while (step >= last) {
    double bu = u, bv = v;
    for (int du = -1; du <= 1; ++du)
      for (int dv = -1; dv <= 1; ++dv) {
        if (!du && !dv) continue;
        const double cu = std::clamp(u + du * step, lo, hi), cv_ = std::clamp(v + dv * step, lo, hi);
        const double c = cost(p, only, cu, cv_);
        if (c < best) best = c, bu = cu, bv = cv_;
      }
    if (bu == u && bv == v) step *= 0.5;
    u = bu, v = bv;
  }
  return best;
}

double percentile(std::vector<float> v, double q) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, size_t(q * double(v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + long(k), v.end());
  return v[k];
}

}  // namespace

DepthFit fit_depth(std::vector<FrameData>& frames, double near, const MotionMaskOptions& options) {
  const int n = int(frames.size());
  Problem p;
  p.frames = &frames;
  std::vector<int> fit_offsets(options.offsets.begin(), options.offsets.begin() + std::min<size_t>(2, options.offsets.size()));
  std::vector<float> disparities;
  for (int i = 0; i < n; ++i) {
    p.samples.push_back(pick_samples(frames[size_t(i)], 600));
    std::vector<std::pair<int, PairGeometry>> pairs;
    for (int j : neighbours(i, n, fit_offsets))
      pairs.push_back({j, pair_geometry(frames[size_t(i)].camera, frames[size_t(j)].camera)});
    p.pairs.push_back(std::move(pairs));
    for (const Sample& s : p.samples.back()) disparities.push_back(s.d);
  }
  p.d_lo = percentile(disparities, 0.05);
  p.d_hi = percentile(disparities, 0.95);
  if (!(p.d_hi > p.d_lo)) throw Error("disp/: the disparity maps are flat (5th and 95th percentiles equal): no depth to place pixels at");

  // The grid: inverse depth at either percentile in [0, 2 / near] (nearest bound of the frames).
  const double top = 2.0 / std::max(near, 1e-6);
  const int cells = 40;
  const double step = top / cells;
  double best = 1e30, bu = 0, bv = 0;
  for (int a = 0; a <= cells; ++a)
    for (int b = 0; b <= cells; ++b) {
      const double c = cost(p, -1, a * step, b * step);
      if (c < best) best = c, bu = a * step, bv = b * step;
    }
  best = refine(p, -1, bu, bv, step, 0.0, top);

  DepthFit fit;
  fit.cost = best;
  fit.global_scale = (bv - bu) / (p.d_hi - p.d_lo);
  fit.global_shift = bu - fit.global_scale * p.d_lo;
  fit.scale.assign(size_t(n), fit.global_scale);
  fit.shift.assign(size_t(n), fit.global_shift);
  if (options.per_frame_fit) {
    for (int i = 0; i < n; ++i) {
      double u = bu, v = bv;
      refine(p, i, u, v, step * 0.5, 0.0, top);
      fit.scale[size_t(i)] = (v - u) / (p.d_hi - p.d_lo);
      fit.shift[size_t(i)] = u - fit.scale[size_t(i)] * p.d_lo;
    }
  }
  return fit;
}

void apply_depth(std::vector<FrameData>& frames, const DepthFit& fit) {
  for (size_t i = 0; i < frames.size(); ++i) {
    frames[i].disp.convertTo(frames[i].inv_depth, CV_32F, fit.scale[i], fit.shift[i]);
    cv::max(frames[i].inv_depth, 1e-4, frames[i].inv_depth);
  }
}

}  // namespace nova::masks

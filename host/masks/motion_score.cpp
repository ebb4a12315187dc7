// The motion score of a frame (masks_steps.hpp): how badly its pixels, placed at their depth,
// fail to match the neighbouring frames where those see them.
#include <algorithm>
#include <cmath>

#include "masks/masks_steps.hpp"

namespace nova::masks {

cv::Mat motion_score(const std::vector<FrameData>& frames, int i, const MotionMaskOptions& options) {
  const FrameData& f = frames[size_t(i)];
  const int w = f.rgb.cols, h = f.rgb.rows;
  std::vector<std::pair<const FrameData*, PairGeometry>> nb;
  for (int j : neighbours(i, int(frames.size()), options.offsets))
    nb.push_back({&frames[size_t(j)], pair_geometry(f.camera, frames[size_t(j)].camera)});
  cv::Mat score(h, w, CV_32F, cv::Scalar(0));
  // Inverse depths tried per pixel: the fitted one times 1 + r for r in [-range, range], so
  // that a disparity wrong by a few percent (a monocular network's) is not motion; the same
  // depth for every neighbour, which a moving point does not fit.
  const int steps = options.depth_search > 0 ? 2 * options.depth_search_steps + 1 : 1;
  std::vector<double> factors;
  for (int k = 0; k < steps; ++k)
    factors.push_back(steps == 1 ? 1.0 : 1.0 + options.depth_search * (2.0 * k / (steps - 1) - 1.0));
  std::vector<float> per;
  const int R = options.match_radius > 0 ? options.match_radius : std::max(1, int(std::lround(w / 240.0)));
  for (int y = 0; y < h; ++y) {
    const cv::Vec3f* src = f.rgb.ptr<cv::Vec3f>(y);
    const float* wsrc = f.inv_depth.ptr<float>(y);
    float* out = score.ptr<float>(y);
    for (int x = 0; x < w; ++x) {
      double best = -1;
      for (double factor : factors) {
        per.clear();
        const double wp = wsrc[x] * factor;
        for (const auto& [g_frame, g] : nb) {
          double bx, by, bw;
          if (!reproject(g, x, y, wp, bx, by, bw)) continue;
          float wj;
          if (!sample_bilinear(g_frame->inv_depth, bx, by, &wj)) continue;
          // Something nearer stands there in the neighbour: it cannot see this point.
          if (wj > bw * (1 + options.occlusion_margin)) continue;
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
              const cv::Vec3f d = row[xx] - src[x];
              colour = std::min(colour, (std::abs(d[0]) + std::abs(d[1]) + std::abs(d[2])) / 3);
              nearest = std::max(nearest, wrow[xx]);
            }
          }
          // A static point cannot vanish: the neighbour seeing behind it is motion.
          const double behind = std::max(0.0, bw - nearest) / std::max(bw, 1e-9);
          per.push_back(float(colour / options.colour_scale + behind / options.depth_scale));
        }
        if (per.empty()) continue;
        std::sort(per.begin(), per.end());
        const size_t half = (per.size() + 1) / 2;
        double s = 0;
        for (size_t k = 0; k < half; ++k) s += per[k];
        s /= double(half);
        if (best < 0 || s < best) best = s;
      }
      if (best > 0) out[x] = float(best);
    }
  }
  return score;
}

}  // namespace nova::masks

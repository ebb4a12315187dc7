// fit_disparity (disparity_fit.hpp): a grid over the inverse depths at the samples' low and
// high disparity (log-spaced inside the scene's depth bounds), then a pattern search around
// the best. Two unknowns and a cost that is cheap to evaluate make a search more robust than
// a gradient method here: the colour cost is flat or multi-modal away from the answer.
#include "nova/train/disparity_fit.hpp"

#include <algorithm>
#include <cmath>

#include "nova/sampling/camera.hpp"
#include "train/float_plane.hpp"
#include "train/parallel_for.hpp"
#include "train/percentile.hpp"
#include "train/reference_width.hpp"

namespace nova {
namespace {

struct Sample {
  int frame;
  double x, y, disparity;
  float colour[3];
};

class ProjectionCost {
 public:
  ProjectionCost(const Scene& scene, const DisparityFitOptions& o) : scene_(scene), o_(o) {
    const double scale = scene.frames.empty() ? 1.0 : detail::reference_scale(scene.frames[0].rgb.width);
    for (const Frame& f : scene.frames) planes_.push_back(blurred_plane(f.rgb, o.blur_px * scale));
    for (size_t i = 0; i < scene.frames.size(); ++i) pick_samples(static_cast<int>(i));
  }

  const std::vector<Sample>& samples() const { return samples_; }

  // Mean truncated colour difference of every sample placed at w = a d + b and seen from its
  // neighbours; samples a neighbour sees inside an object mask are not compared there. Only
  // frame `only`'s samples where it is >= 0.
  double operator()(double a, double b, int only = -1) const {
    double sum = 0;
    size_t count = 0;
    const int F = static_cast<int>(scene_.frames.size());
    for (const Sample& s : samples_) {
      if (only >= 0 && s.frame != only) continue;
      const double w = a * s.disparity + b;
      const Frame& f = scene_.frames[static_cast<size_t>(s.frame)];
      for (int d : o_.neighbours) {
        const int g = s.frame + d;
        if (g < 0 || g >= F) continue;
        if (!(w > 1e-6)) {  // at or beyond infinity: no place to be seen from
          sum += o_.truncate;
          ++count;
          continue;
        }
        const Frame& fg = scene_.frames[static_cast<size_t>(g)];
        const auto p = camera_project(fg.camera, camera_unproject(f.camera, s.x, s.y, 1.0 / w));
        const FloatPlane& pg = planes_[static_cast<size_t>(g)];
        if (p[2] <= 0 || !pg.contains(p[0], p[1])) {
          sum += o_.truncate;
          ++count;
          continue;
        }
        if (o_.use_masks && fg.masks.at(0).at(static_cast<int>(std::lround(p[0])), static_cast<int>(std::lround(p[1]))) < 128) continue;
        double diff = 0;
        for (int c = 0; c < 3; ++c) diff += std::fabs(pg.sample(p[0], p[1], c) - s.colour[c]);
        sum += std::min(diff / 3, o_.truncate);
        ++count;
      }
    }
    return count ? sum / static_cast<double>(count) : o_.truncate;
  }

 private:
  // The frame's most textured background pixels (colour gradient, away from the masks' edges):
  // flat regions match at any depth.
  void pick_samples(int i) {
    const Frame& f = scene_.frames[static_cast<size_t>(i)];
    const FloatPlane& p = planes_[static_cast<size_t>(i)];
    const Image8& bg = f.masks.at(0);
    const int W = p.width, H = p.height;
    const int want = o_.samples_per_frame;
    const int stride = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(W) * H / (4.0 * want))));
    std::vector<std::pair<double, Sample>> candidates;
    for (int y = 2; y < H - 2; y += stride)
      for (int x = 2; x < W - 2; x += stride) {
        bool background = true;
        for (int dy = -2; dy <= 2 && background && o_.use_masks; ++dy)
          for (int dx = -2; dx <= 2 && background; ++dx) background = bg.at(x + dx, y + dy) >= 128;
        const float d = f.disparity.data[static_cast<size_t>(y) * f.disparity.width + x];
        if (!background || !std::isfinite(d)) continue;
        double g = 0;
        for (int c = 0; c < 3; ++c) g += std::fabs(p.at(x + 1, y, c) - p.at(x - 1, y, c)) + std::fabs(p.at(x, y + 1, c) - p.at(x, y - 1, c));
        Sample s{i, static_cast<double>(x), static_cast<double>(y), d, {p.at(x, y, 0), p.at(x, y, 1), p.at(x, y, 2)}};
        candidates.push_back({g, s});
      }
    const size_t keep = std::min(candidates.size(), static_cast<size_t>(want));
    std::partial_sort(candidates.begin(), candidates.begin() + static_cast<long>(keep), candidates.end(),
                      [](const auto& l, const auto& r) { return l.first > r.first; });
    for (size_t k = 0; k < keep; ++k) samples_.push_back(candidates[k].second);
  }

  const Scene& scene_;
  const DisparityFitOptions& o_;
  std::vector<FloatPlane> planes_;
  std::vector<Sample> samples_;
};

}  // namespace

DisparityFit fit_disparity(const Scene& scene, const DisparityFitOptions& options) {
  DisparityFit fit;
  if (scene.frames.size() < 2 || scene.frames[0].disparity.empty()) return fit;
  const ProjectionCost cost(scene, options);
  const auto& samples = cost.samples();
  fit.samples = static_cast<int>(samples.size());
  if (samples.size() < 16) return fit;
  std::vector<double> disparity;
  for (const Sample& s : samples) disparity.push_back(s.disparity);
  const double d_lo = detail::percentile(disparity, 0.05), d_hi = detail::percentile(disparity, 0.95);
  if (!(d_hi > d_lo)) return fit;

  // Inverse depths inside the scene's bounds, widened (the bounds are COLMAP's or a guess).
  double near = 0, far = 0;
  for (const Frame& f : scene.frames) {
    if (f.near > 0) near = near > 0 ? std::min(near, f.near) : f.near;
    far = std::max(far, f.far);
  }
  const double w_min = far > 0 ? 0.25 / far : 1e-3, w_max = near > 0 ? 4.0 / near : 10.0;
  // (u, v) = log inverse depth at d_lo and d_hi.
  auto line = [&](double u, double v) {
    const double lo = std::exp(u), hi = std::exp(v);
    const double a = (hi - lo) / (d_hi - d_lo);
    return std::pair{a, lo - a * d_lo};
  };
  // The cost at (u, v), on frame `only`'s samples (all where < 0).
  auto eval = [&](double u, double v, int only = -1) {
    const auto [a, b] = line(u, v);
    return cost(a, b, only);
  };
  constexpr int kGrid = 24;
  const double u0 = std::log(w_min), step = (std::log(w_max) - u0) / (kGrid - 1);
  std::vector<std::pair<int, int>> grid;
  for (int i = 0; i < kGrid; ++i)
    for (int j = i; j < kGrid; ++j) grid.push_back({i, j});  // nearer where the disparity is larger
  std::vector<double> grid_cost(grid.size());
  detail::parallel_for(grid.size(), [&](size_t g) {
    grid_cost[g] = eval(u0 + grid[g].first * step, u0 + grid[g].second * step);
  });
  double best = 1e300, best_constant = 1e300, bu = u0, bv = u0;
  for (size_t g = 0; g < grid.size(); ++g) {
    const auto [i, j] = grid[g];
    const double c = grid_cost[g];
    if (i == j) best_constant = std::min(best_constant, c);
    if (c < best) {
      best = c;
      bu = u0 + i * step;
      bv = u0 + j * step;
    }
  }
  // Pattern search from (u, v) with steps h0 / 2^k down to h0 / 32, on frame `only`'s samples
  // (all where < 0).
  auto refine = [&](double& u, double& v, double c0, double h0, int only) {
    double c_best = c0;
    for (double h = h0; h > h0 / 32; h /= 2) {
      bool moved = true;
      while (moved) {
        moved = false;
        for (const auto& [du, dv] : {std::pair{h, 0.0}, {-h, 0.0}, {0.0, h}, {0.0, -h}, {h, h}, {-h, -h}}) {
          if (v + dv < u + du) continue;
          const double c = eval(u + du, v + dv, only);
          if (c < c_best) {
            c_best = c;
            u += du;
            v += dv;
            moved = true;
          }
        }
      }
    }
    return c_best;
  };
  best = refine(bu, bv, best, step / 2, -1);
  const auto [a, b] = line(bu, bv);
  fit.scale = a;
  fit.shift = b;
  fit.cost = best;
  // A fit no better than some constant depth says the frames show too little parallax to
  // place the disparity (a tripod shot): no fit.
  fit.ok = a > 0 && best < 0.98 * best_constant;
  if (options.per_frame)
    for (int i = 0; i < static_cast<int>(scene.frames.size()); ++i) {
      double u = bu, v = bv;
      refine(u, v, eval(u, v, i), step / 4, i);
      const auto [ai, bi] = line(u, v);
      fit.frame_scale.push_back(ai);
      fit.frame_shift.push_back(bi);
    }
  return fit;
}

}  // namespace nova

// Direct alignment of one object between two frames (motion_alignment.hpp): Levenberg-Marquardt
// on a turn (axis-angle about the points' centroid) and a translation, with central-difference
// Jacobians of residuals sampled from blurred images. Six unknowns and about a thousand points
// make each step a few hundred thousand bilinear samples, so the host does it.
#include "nova/train/motion_alignment.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <utility>

#include "nova/runtime/error.hpp"
#include "nova/train/silhouette_axis.hpp"
#include "train/float_plane.hpp"
#include "train/parallel_for.hpp"
#include "train/reference_width.hpp"
#include "train/square_min.hpp"

namespace nova {
namespace {

constexpr Mat34 kIdentity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};

struct Point {
  Vec3 x;
  std::array<double, 3> colour;
  double px, py;  // its pixel in its own view
  int view = 0;    // which of the placed views it comes from
};

// Solves the 6x6 system A d = b (Gaussian elimination with partial pivoting); false if singular.
bool solve6(std::array<double, 36> a, std::array<double, 6> b, std::array<double, 6>& d) {
  for (int c = 0; c < 6; ++c) {
    int piv = c;
    for (int r = c + 1; r < 6; ++r)
      if (std::fabs(a[static_cast<size_t>(r * 6 + c)]) > std::fabs(a[static_cast<size_t>(piv * 6 + c)])) piv = r;
    if (std::fabs(a[static_cast<size_t>(piv * 6 + c)]) < 1e-300) return false;
    for (int k = 0; k < 6; ++k) std::swap(a[static_cast<size_t>(c * 6 + k)], a[static_cast<size_t>(piv * 6 + k)]);
    std::swap(b[static_cast<size_t>(c)], b[static_cast<size_t>(piv)]);
    for (int r = c + 1; r < 6; ++r) {
      const double f = a[static_cast<size_t>(r * 6 + c)] / a[static_cast<size_t>(c * 6 + c)];
      for (int k = c; k < 6; ++k) a[static_cast<size_t>(r * 6 + k)] -= f * a[static_cast<size_t>(c * 6 + k)];
      b[static_cast<size_t>(r)] -= f * b[static_cast<size_t>(c)];
    }
  }
  for (int r = 5; r >= 0; --r) {
    double s = b[static_cast<size_t>(r)];
    for (int k = r + 1; k < 6; ++k) s -= a[static_cast<size_t>(r * 6 + k)] * d[static_cast<size_t>(k)];
    d[static_cast<size_t>(r)] = s / a[static_cast<size_t>(r * 6 + r)];
  }
  return true;
}

constexpr int kResiduals = 5;  // per point: 3 colour, 1 depth, 1 mask

class Aligner {
 public:
  Aligner(const std::vector<PlacedView>& a, const ObjectView& b, const AlignmentOptions& o) : a_(a), b_(b), o_(o) {
    for (size_t v = 0; v < a.size(); ++v) add_points(a[v], static_cast<int>(v));
    // The turn is about the reference view's centroid (all points' where it has none).
    const bool reference = std::any_of(points_.begin(), points_.end(), [](const Point& p) { return p.view == 0; });
    const double n = static_cast<double>(std::max<long>(
        std::count_if(points_.begin(), points_.end(), [&](const Point& p) { return p.view == 0 || !reference; }), 1));
    for (const Point& p : points_)
      if (p.view == 0 || !reference)
        for (int k = 0; k < 3; ++k) centre_[k] += p.x[k] / n;
    for (const Point& p : points_)
      for (int k = 0; k < 3; ++k) size_ += (p.x[k] - centre_[k]) * (p.x[k] - centre_[k]);
    size_ = std::sqrt(size_ / static_cast<double>(std::max<size_t>(points_.size(), 1)));
  }

  size_t points() const { return points_.size(); }
  const Vec3& centre() const { return centre_; }

  // Sets the blur level: the second view's images and the points' colours.
  void level(double sigma) {
    rgb_ = blurred_plane(*b_.rgb, sigma);
    mask_ = blurred_plane(*b_.mask, sigma);
    for (size_t v = 0; v < a_.size(); ++v) {
      const FloatPlane ia = blurred_plane(*a_[v].view.rgb, sigma);
      for (Point& p : points_)
        if (p.view == static_cast<int>(v))
          for (int c = 0; c < 3; ++c) p.colour[static_cast<size_t>(c)] = ia.sample(p.px, p.py, c);
    }
  }

  // The residuals of every point under parameters q (turn, translation): kResiduals per point.
  void residuals(const std::array<double, 6>& q, std::vector<double>& r) const {
    const Mat3 R = axis_angle_to_matrix({q[0], q[1], q[2]});
    const Camera& cb = *b_.camera;
    r.assign(points_.size() * kResiduals, 0.0);
    for (size_t i = 0; i < points_.size(); ++i) {
      const Point& p = points_[i];
      Vec3 y{};
      for (int k = 0; k < 3; ++k) {
        y[k] = centre_[k] + q[static_cast<size_t>(3 + k)];
        for (int j = 0; j < 3; ++j) y[k] += R[static_cast<size_t>(k * 3 + j)] * (p.x[j] - centre_[j]);
      }
      const auto [px, py, z] = camera_project(cb, y);
      double* ri = r.data() + i * kResiduals;
      if (z <= 0 || !rgb_.contains(px, py)) {
        ri[4] = o_.mask_weight;  // left the picture: as outside the mask
        continue;
      }
      const double inside = std::clamp(static_cast<double>(mask_.sample(px, py, 0)), 0.0, 1.0);
      const double w = std::sqrt(inside);
      for (int c = 0; c < 3; ++c) ri[c] = w * (rgb_.sample(px, py, c) - p.colour[static_cast<size_t>(c)]);
      const ImageF& d = *b_.depth;
      const float zb = d.data[static_cast<size_t>(std::lround(py)) * d.width + std::lround(px)];
      if (zb > 0 && std::isfinite(zb)) ri[3] = o_.depth_weight * w * std::clamp((z - zb) / zb, -0.5, 0.5);
      ri[4] = o_.mask_weight * std::max(0.0, 1 - 2 * inside);  // only outside: the eroded points near the edge stay free
    }
  }

  // Huber weights per point (on the norm of its residuals) and the robust cost.
  double weights(const std::vector<double>& r, std::vector<double>& w) const {
    constexpr double delta = 0.15;
    w.assign(points_.size(), 1.0);
    double cost = 0;
    for (size_t i = 0; i < points_.size(); ++i) {
      double s = 0;
      for (int k = 0; k < kResiduals; ++k) s += r[i * kResiduals + k] * r[i * kResiduals + k];
      const double n = std::sqrt(s);
      if (n > delta) {
        w[i] = delta / n;
        cost += delta * (2 * n - delta);
      } else {
        cost += s;
      }
    }
    return cost;
  }

  // The turn's damping: its weight (per radian squared, for all points) and its cost.
  double prior_weight() const { return o_.turn_prior * static_cast<double>(points_.size()); }
  double prior(const std::array<double, 6>& q) const { return prior_weight() * (q[0] * q[0] + q[1] * q[1] + q[2] * q[2]); }

  // Levenberg-Marquardt at the current level from q; returns the final cost. With `hold_turn`
  // only the translation moves.
  double optimise(std::array<double, 6>& q, int iterations, bool hold_turn) const {
    std::vector<double> r, w, rp, rm;
    std::vector<double> J;
    double lambda = 1e-3;
    residuals(q, r);
    double cost = weights(r, w) + prior(q);
    const double h[6] = {1e-3, 1e-3, 1e-3, 1e-3 * size_, 1e-3 * size_, 1e-3 * size_};
    const size_t n = r.size();
    for (int it = 0; it < iterations; ++it) {
      J.assign(n * 6, 0.0);
      for (int j = 0; j < 6; ++j) {
        std::array<double, 6> qp = q, qm = q;
        qp[static_cast<size_t>(j)] += h[j];
        qm[static_cast<size_t>(j)] -= h[j];
        residuals(qp, rp);
        residuals(qm, rm);
        for (size_t i = 0; i < n; ++i) J[i * 6 + static_cast<size_t>(j)] = (rp[i] - rm[i]) / (2 * h[j]);
      }
      std::array<double, 36> A{};
      std::array<double, 6> g{};
      for (size_t i = 0; i < n; ++i) {
        const double wi = w[i / kResiduals];
        for (int a = 0; a < 6; ++a) {
          g[static_cast<size_t>(a)] -= wi * J[i * 6 + static_cast<size_t>(a)] * r[i];
          for (int b = 0; b < 6; ++b)
            A[static_cast<size_t>(a * 6 + b)] += wi * J[i * 6 + static_cast<size_t>(a)] * J[i * 6 + static_cast<size_t>(b)];
        }
      }
      const double pw = prior_weight();
      for (int a = 0; a < 3; ++a) {
        A[static_cast<size_t>(a * 7)] += pw;
        g[static_cast<size_t>(a)] -= pw * q[static_cast<size_t>(a)];
        if (hold_turn) {  // the turn's rows and columns out of the system: d = 0 there
          for (int b = 0; b < 6; ++b) A[static_cast<size_t>(a * 6 + b)] = A[static_cast<size_t>(b * 6 + a)] = 0;
          A[static_cast<size_t>(a * 7)] = 1;
          g[static_cast<size_t>(a)] = 0;
        }
      }
      bool improved = false;
      for (int tries = 0; tries < 6 && !improved; ++tries) {
        std::array<double, 36> Ad = A;
        for (int a = 0; a < 6; ++a) Ad[static_cast<size_t>(a * 7)] += lambda * (A[static_cast<size_t>(a * 7)] + 1e-9);
        std::array<double, 6> d{};
        if (!solve6(Ad, g, d)) break;
        std::array<double, 6> qn = q;
        for (int a = 0; a < 6; ++a) qn[static_cast<size_t>(a)] += d[static_cast<size_t>(a)];
        std::vector<double> rn, wn;
        residuals(qn, rn);
        const double cn = weights(rn, wn) + prior(qn);
        if (cn < cost) {
          q = qn;
          r = std::move(rn);
          w = std::move(wn);
          cost = cn;
          lambda = std::max(lambda * 0.3, 1e-7);
          improved = true;
        } else {
          lambda *= 10;
        }
      }
      if (!improved) break;
    }
    return cost;
  }

 private:
  // The interior pixels of one view with a known depth (about max_points of them), placed in
  // the reference frame by the view's map.
  void add_points(const PlacedView& pv, int view) {
    const Image8& m = *pv.view.mask;
    const ImageF& d = *pv.view.depth;
    // A pixel within e pixels (city-block) of the mask's edge is left out: there the disparity
    // mixes the object's depth with what lies behind it. A view left with too few pixels gives
    // no turn (the anchors' shift alone).
    const int e = std::max(1, o_.edge_px);
    auto inside = [&](int x, int y) {
      if (x < e || y < e || x >= m.width - e || y >= m.height - e) return false;
      for (int dy = -e; dy <= e; ++dy)
        for (int dx = -e; dx <= e; ++dx)
          if (std::abs(dx) + std::abs(dy) <= e && m.at(x + dx, y + dy) < 128) return false;
      return true;
    };
    size_t count = 0;
    for (int y = 0; y < m.height; ++y)
      for (int x = 0; x < m.width; ++x) count += inside(x, y);
    const int stride = std::max(1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(count) / std::max(o_.max_points, 1)))));
    for (int y = 0; y < m.height; y += stride)
      for (int x = 0; x < m.width; x += stride) {
        const float z = d.data[static_cast<size_t>(y) * d.width + x];
        if (!inside(x, y) || !(z > 0) || !std::isfinite(z)) continue;
        const Vec3 world = camera_unproject(*pv.view.camera, x, y, z);
        points_.push_back({apply_rigid(pv.to_reference, world), {}, static_cast<double>(x), static_cast<double>(y), view});
      }
  }

  const std::vector<PlacedView>& a_;
  const ObjectView& b_;
  const AlignmentOptions& o_;
  std::vector<Point> points_;
  Vec3 centre_{0, 0, 0};
  double size_ = 0;
  FloatPlane rgb_, mask_;
};

// align_object from the turn `start_turn` (axis-angle), held there with `hold_turn`.
ObjectAlignment align_views(const std::vector<PlacedView>& a, const ObjectView& b, const Vec3& translation,
                            const AlignmentOptions& options, const Vec3& start_turn, bool hold_turn) {
  ObjectAlignment out;
  if (a.empty()) return out;
  Aligner al(a, b, options);
  out.points = static_cast<int>(al.points());
  std::array<double, 6> q{start_turn[0], start_turn[1], start_turn[2], translation[0], translation[1], translation[2]};
  if (al.points() >= kMinAlignmentPoints) {
    const double scale = detail::reference_scale(b.rgb->width);
    double cost = 0;
    for (double sigma : options.blur_px) {
      al.level(sigma * scale);
      cost = al.optimise(q, options.iterations, hold_turn);
    }
    out.residual = cost / static_cast<double>(al.points());
  }
  const Vec3& c = al.centre();
  out.motion = rigid_about(axis_angle_to_matrix({q[0], q[1], q[2]}), c, {c[0] + q[3], c[1] + q[4], c[2] + q[5]});
  out.turn = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
  return out;
}

}  // namespace

ObjectAlignment align_object(const std::vector<PlacedView>& a, const ObjectView& b, const Vec3& translation,
                             const AlignmentOptions& options) {
  return align_views(a, b, translation, options, {0, 0, 0}, false);
}

ObjectAlignment align_object(const ObjectView& a, const ObjectView& b, const Vec3& translation,
                             const AlignmentOptions& options) {
  return align_object(std::vector<PlacedView>{{a, kIdentity}}, b, translation, options);
}

ImageF nearest_depth_within(const ImageF& depth, const Image8& mask, int reach) {
  const size_t W = static_cast<size_t>(depth.width), H = static_cast<size_t>(depth.height);
  if (mask.width != depth.width || mask.height != depth.height)
    throw Error("nearest_depth_within: mask and depth differ in size", kExitInternal);
  // The mask's valid depths, every other cell out of reach of the minimum.
  std::vector<float> v(W * H, std::numeric_limits<float>::infinity());
  for (size_t y = 0; y < H; ++y)
    for (size_t x = 0; x < W; ++x) {
      const float z = depth.data[y * W + x];
      if (mask.at(static_cast<int>(x), static_cast<int>(y)) >= 128 && z > 0 && std::isfinite(z)) v[y * W + x] = z;
    }
  const std::vector<float> nearest = detail::square_min(v, W, H, reach);
  ImageF out = depth;
  for (size_t y = 0; y < H; ++y)
    for (size_t x = 0; x < W; ++x)
      if (mask.at(static_cast<int>(x), static_cast<int>(y)) >= 128 && std::isfinite(nearest[y * W + x]))
        out.data[y * W + x] = nearest[y * W + x];
  return out;
}

namespace {

// The rotation angle of a rigid map's rotation (radians).
double turn_of(const Mat34& m) { return std::acos(std::clamp((m[0] + m[5] + m[10] - 1) / 2, -1.0, 1.0)); }

// View a's object aligned to view b where b aligned back to a agrees (turns_agree), else the
// anchors' shift alone.
ObjectAlignment consistent_step(const ObjectView& a, const ObjectView& b, const Vec3& shift, const AlignmentOptions& o) {
  ObjectAlignment forward = align_object(a, b, shift, o);
  if (!(o.consistency > 0)) return forward;
  const Mat34 backward = align_object(b, a, Vec3{-shift[0], -shift[1], -shift[2]}, o).motion;
  if (turns_agree(forward.motion, backward, o)) return forward;
  forward.motion = kIdentity;
  for (size_t d = 0; d < 3; ++d) forward.motion[d * 4 + 3] = shift[d];
  return forward;
}

// The pairs that did not align reliably (AlignmentOptions::bridge_ratio) between two that did,
// each with the turn interpolated from those two (axis-angle); `fixed` pairs (turned by their
// silhouettes) count as reliable. Pairs that keep their own turn are not listed.
std::vector<std::pair<size_t, Vec3>> bridged_turns(const std::vector<ObjectAlignment>& step, const std::vector<bool>& fixed,
                                                   double ratio) {
  std::vector<double> costs;
  for (size_t j = 1; j < step.size(); ++j)
    if (step[j].points >= kMinAlignmentPoints) costs.push_back(step[j].residual);
  if (costs.size() < 3) return {};  // too few pairs to say what a good one leaves
  std::nth_element(costs.begin(), costs.begin() + static_cast<long>(costs.size() / 2), costs.end());
  const double limit = ratio * costs[costs.size() / 2];
  std::vector<bool> reliable(step.size(), false);
  std::vector<Vec3> turn(step.size());
  for (size_t j = 1; j < step.size(); ++j) {
    reliable[j] = fixed[j] || (step[j].points >= kMinAlignmentPoints && step[j].residual <= limit);
    const Mat34& m = step[j].motion;
    if (reliable[j]) turn[j] = matrix_to_axis_angle({m[0], m[1], m[2], m[4], m[5], m[6], m[8], m[9], m[10]});
  }
  std::vector<std::pair<size_t, Vec3>> out;
  for (size_t j = 2; j + 1 < step.size(); ++j) {
    if (reliable[j]) continue;
    size_t before = j - 1, after = j + 1;
    while (before > 1 && !reliable[before]) --before;
    while (after + 1 < step.size() && !reliable[after]) ++after;
    if (!reliable[before] || !reliable[after]) continue;  // at an end of the video: its own
    const double f = static_cast<double>(j - before) / static_cast<double>(after - before);
    Vec3 w{};
    for (size_t d = 0; d < 3; ++d) w[d] = (1 - f) * turn[before][d] + f * turn[after][d];
    out.emplace_back(j, w);
  }
  return out;
}

}  // namespace

bool turns_agree(const Mat34& forward, const Mat34& backward, const AlignmentOptions& options) {
  constexpr double kDegree = 3.14159265358979323846 / 180.0;
  const double gap = turn_of(compose_rigid(backward, forward));
  return gap <= std::max(options.consistency * turn_of(forward), options.consistency_floor_deg * kDegree);
}

std::vector<Mat34> track_object(const std::vector<ObjectView>& given, const std::vector<Vec3>& anchors,
                                const AlignmentOptions& options) {
  if (anchors.size() != given.size()) throw Error("track_object: " + std::to_string(given.size()) + " views but " +
                                                  std::to_string(anchors.size()) + " anchors", kExitInternal);
  if (given.empty()) return {};
  std::vector<ObjectView> views = given;
  std::vector<ImageF> nearest;  // the views' depths, nearest within depth_reach_px
  if (options.depth_reach_px > 0) {
    nearest.resize(given.size());
    detail::parallel_for(given.size(), [&](size_t i) {
      const int reach = static_cast<int>(std::lround(options.depth_reach_px * detail::reference_scale(given[i].rgb->width)));
      nearest[i] = nearest_depth_within(*given[i].depth, *given[i].mask, reach);
    });
    for (size_t i = 0; i < views.size(); ++i) views[i].depth = &nearest[i];
  }
  // The anchors' move from view j - 1 to view j: each alignment's starting translation.
  const auto shift = [&](size_t j) {
    Vec3 s{};
    for (size_t d = 0; d < 3; ++d) s[d] = anchors[j][d] - anchors[j - 1][d];
    return s;
  };
  std::vector<Mat34> poses(1, kIdentity);
  for (size_t d = 0; d < 3; ++d) poses[0][d * 4 + 3] = anchors[0][d];
  poses.reserve(views.size());
  if (options.window <= 1) {
    // Each frame aligned to the one before alone: the pairs do not depend on each other's
    // poses, so they run at once and the poses are chained after.
    std::vector<ObjectAlignment> step(views.size());
    detail::parallel_for(views.size() - 1, [&](size_t p) {
      step[p + 1] = consistent_step(views[p], views[p + 1], shift(p + 1), options);
    });
    // A pair too thin to align by its interior (a rod) turns as its silhouettes' axes do.
    std::vector<std::optional<Vec3>> axes;
    std::vector<bool> by_silhouette(views.size(), false);
    for (size_t j = 1; j < views.size(); ++j)
      if (options.silhouette_turns && step[j].points < kMinAlignmentPoints) {
        if (axes.empty()) axes = silhouette_axes(given, anchors);
        if (axes[j - 1] && axes[j]) {
          step[j].motion = turn_onto(*axes[j - 1], *axes[j], anchors[j - 1], anchors[j]);
          by_silhouette[j] = true;
        }
      }
    // A pair that aligned badly between two that aligned well takes their turn and, where it
    // has the points, the translation that best aligns it under that turn (else the anchors'
    // shift).
    if (options.bridge_ratio > 0) {
      const std::vector<std::pair<size_t, Vec3>> bridged = bridged_turns(step, by_silhouette, options.bridge_ratio);
      detail::parallel_for(bridged.size(), [&](size_t i) {
        const auto& [j, w] = bridged[i];
        step[j].motion = step[j].points >= kMinAlignmentPoints
                             ? align_views({{views[j - 1], kIdentity}}, views[j], shift(j), options, w, true).motion
                             : rigid_about(axis_angle_to_matrix(w), anchors[j - 1], anchors[j]);
      });
    }
    for (size_t j = 1; j < views.size(); ++j) poses.push_back(compose_rigid(step[j].motion, poses[j - 1]));
    return poses;
  }
  for (size_t j = 1; j < views.size(); ++j) {
    // The last `window` views, each placed where the object stood in view j - 1.
    std::vector<PlacedView> earlier;
    for (size_t i = j; i-- > 0 && earlier.size() < static_cast<size_t>(options.window);)
      earlier.push_back({views[i], i + 1 == j ? kIdentity : compose_rigid(poses[j - 1], invert_rigid(poses[i]))});
    poses.push_back(compose_rigid(align_object(earlier, views[j], shift(j), options).motion, poses[j - 1]));
  }
  return poses;
}

}  // namespace nova

#include "nova/train/silhouette_axis.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

#include "nova/sampling/camera.hpp"
#include "nova/sampling/rigid_motion.hpp"

namespace nova {
namespace {

double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
Vec3 scaled(const Vec3& a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
Vec3 plus(const Vec3& a, const Vec3& b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
Vec3 minus(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec3 unit(const Vec3& a) {
  const double n = std::sqrt(dot(a, a));
  return n > 0 ? scaled(a, 1 / n) : a;
}

Vec3 rotate(const Mat3& r, const Vec3& v) {
  return {r[0] * v[0] + r[1] * v[1] + r[2] * v[2], r[3] * v[0] + r[4] * v[1] + r[5] * v[2],
          r[6] * v[0] + r[7] * v[1] + r[8] * v[2]};
}

// The smallest rotation that takes unit `from` onto unit `to`.
Mat3 rotation_onto(const Vec3& from, const Vec3& to) {
  const Vec3 axis = cross(from, to);
  const double s = std::sqrt(dot(axis, axis)), c = dot(from, to);
  if (s < 1e-12) return {1, 0, 0, 0, 1, 0, 0, 0, 1};
  return axis_angle_to_matrix(scaled(axis, std::atan2(s, c) / s));
}

}  // namespace

SilhouetteAxis silhouette_axis(const ObjectView& view, const Vec3& anchor) {
  SilhouetteAxis out;
  const Image8& m = *view.mask;
  double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0, syy = 0;
  for (int y = 0; y < m.height; ++y)
    for (int x = 0; x < m.width; ++x)
      if (m.at(x, y) >= 128) {
        n += 1;
        sx += x;
        sy += y;
        sxx += static_cast<double>(x) * x;
        sxy += static_cast<double>(x) * y;
        syy += static_cast<double>(y) * y;
        if (x == 0 || y == 0 || x == m.width - 1 || y == m.height - 1) out.clipped = true;
      }
  if (n < 3) return out;
  const double mx = sx / n, my = sy / n;
  const double cxx = sxx / n - mx * mx, cxy = sxy / n - mx * my, cyy = syy / n - my * my;
  // Principal variances of the 2x2 covariance and the major one's direction.
  const double half_trace = 0.5 * (cxx + cyy), root = std::sqrt(0.25 * (cxx - cyy) * (cxx - cyy) + cxy * cxy);
  const double major = half_trace + root, minor = std::max(half_trace - root, 1e-6);
  out.elongated = major >= kElongation * minor;
  const double angle = 0.5 * std::atan2(2 * cxy, cxx - cyy);
  const Camera& cam = *view.camera;
  const Vec3 at = camera_project(cam, anchor);
  if (!(at[2] > 0)) {
    out.elongated = false;
    return out;
  }
  // The image direction placed at the anchor's depth, made square to the line of sight.
  const Vec3 along = camera_unproject(cam, at[0] + std::cos(angle), at[1] + std::sin(angle), at[2]);
  out.toward = unit(Vec3{cam.position(0) - anchor[0], cam.position(1) - anchor[1], cam.position(2) - anchor[2]});
  const Vec3 u = minus(along, anchor);
  out.in_plane = unit(minus(u, scaled(out.toward, dot(u, out.toward))));
  // A uniform segment of length L has variance L^2 / 12 along it.
  out.length = std::sqrt(12.0 * major) * at[2] / cam.fx;
  return out;
}

std::vector<std::optional<Vec3>> silhouette_axes(const std::vector<ObjectView>& views, const std::vector<Vec3>& anchors) {
  const size_t V = views.size();
  std::vector<SilhouetteAxis> s(V);
  for (size_t i = 0; i < V; ++i) s[i] = silhouette_axis(views[i], anchors[i]);
  // The object's own length: the longest view that the border does not cut (any, where all are cut).
  double full = 0;
  for (bool cut_too : {false, true}) {
    for (const SilhouetteAxis& a : s)
      if (a.elongated && (cut_too || !a.clipped)) full = std::max(full, a.length);
    if (full > 0) break;
  }
  std::vector<std::optional<Vec3>> out(V);
  if (!(full > 0)) return out;
  // Each view's tilt out of the image plane (its cosine); a cut view takes its nearest uncut one's.
  std::vector<double> cosine(V, 1.0);
  for (size_t i = 0; i < V; ++i) cosine[i] = std::min(1.0, s[i].length / full);
  for (size_t i = 0; i < V; ++i) {
    if (!s[i].clipped) continue;
    for (size_t d = 1; d < V; ++d) {
      const bool below = d <= i && s[i - d].elongated && !s[i - d].clipped;
      const bool above = i + d < V && s[i + d].elongated && !s[i + d].clipped;
      if (below || above) {
        cosine[i] = cosine[below ? i - d : i + d];
        break;
      }
    }
  }
  std::optional<Vec3> last, before_last;
  for (size_t i = 0; i < V; ++i) {
    if (!s[i].elongated) continue;
    const double c = cosine[i], sn = std::sqrt(std::max(0.0, 1 - c * c));
    // Where the axis is expected: the last turn carried on, else the last axis.
    std::optional<Vec3> expected = last;
    if (last && before_last) expected = rotate(rotation_onto(*before_last, *last), *last);
    Vec3 best = plus(scaled(s[i].in_plane, c), scaled(s[i].toward, sn));
    double best_fit = -2;
    for (double tilt : {1.0, -1.0})
      for (double end : {1.0, -1.0}) {
        const Vec3 axis = scaled(plus(scaled(s[i].in_plane, c), scaled(s[i].toward, tilt * sn)), end);
        const double fit = expected ? dot(axis, *expected) : (tilt > 0 && end > 0 ? 1.0 : -1.0);
        if (fit > best_fit) {
          best_fit = fit;
          best = axis;
        }
      }
    out[i] = unit(best);
    before_last = last;
    last = out[i];
  }
  return out;
}

Mat34 turn_onto(const Vec3& from, const Vec3& to, const Vec3& pivot, const Vec3& destination) {
  // A rod and its reverse are one rod: the smaller of the two turns.
  const Vec3 target = dot(from, to) < 0 ? scaled(to, -1) : to;
  return rigid_about(rotation_onto(unit(from), unit(target)), pivot, destination);
}

}  // namespace nova

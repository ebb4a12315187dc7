// Ray intersections and normals of the synthetic shapes (see synth.hpp for their sizes).
// Quadrics and boxes are solved in closed form; the torus (a quartic) by sphere tracing its
// exact distance function inside its bounding sphere, which is robust where a closed-form
// quartic solver loses precision at grazing angles.
#include <algorithm>

#include "data/synth_geometry.hpp"
#include "nova/runtime/error.hpp"

namespace nova::synth {
namespace {

constexpr double kEps = 1e-9;

// Nearest positive root of |o + t d - c|^2 = r^2.
double hit_sphere(V3 o, V3 d, V3 c, double r) {
  const V3 oc = sub(o, c);
  const double a = dot(d, d), b = dot(oc, d), cc = dot(oc, oc) - r * r;
  const double disc = b * b - a * cc;
  if (disc < 0) return -1;
  const double sq = std::sqrt(disc);
  double t = (-b - sq) / a;
  if (t <= kEps) t = (-b + sq) / a;
  return t > kEps ? t : -1;
}

// Slab method against the box [lo, hi].
double hit_aabb(V3 o, V3 d, V3 lo, V3 hi) {
  double t0 = -1e300, t1 = 1e300;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(d[k]) < 1e-15) {
      if (o[k] < lo[k] || o[k] > hi[k]) return -1;
      continue;
    }
    double a = (lo[k] - o[k]) / d[k], b = (hi[k] - o[k]) / d[k];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  }
  if (t0 > t1 || t1 <= kEps) return -1;
  return t0 > kEps ? t0 : t1;
}

// Capped cylinder about the y axis: part 0 the side, part 1 the caps.
ShapeHit hit_cylinder(V3 o, V3 d, double r, double h) {
  ShapeHit best;
  auto take = [&](double t, int part) {
    if (t > kEps && (best.t < 0 || t < best.t)) best = {t, part};
  };
  const double a = d[0] * d[0] + d[2] * d[2];
  if (a > 1e-300) {
    const double b = o[0] * d[0] + o[2] * d[2], c = o[0] * o[0] + o[2] * o[2] - r * r;
    const double disc = b * b - a * c;
    if (disc >= 0) {
      const double sq = std::sqrt(disc);
      for (double t : {(-b - sq) / a, (-b + sq) / a})
        if (std::abs(o[1] + t * d[1]) <= h) take(t, 0);
    }
  }
  if (std::abs(d[1]) > 1e-300)
    for (double y : {-h, h}) {
      const double t = (y - o[1]) / d[1];
      const double x = o[0] + t * d[0], z = o[2] + t * d[2];
      if (x * x + z * z <= r * r) take(t, 1);
    }
  return best;
}

V3 swap_xy(V3 v) { return {v[1], v[0], v[2]}; }

double torus_distance(V3 p, double big, double small) {
  const double q = std::sqrt(p[0] * p[0] + p[2] * p[2]) - big;
  return std::sqrt(q * q + p[1] * p[1]) - small;
}

double hit_torus(V3 o, V3 d, double big, double small) {
  // Enter and leave the bounding sphere, then march by the distance (a safe step).
  const double a = dot(d, d), b = dot(o, d), rb = big + small;
  const double disc = b * b - a * (dot(o, o) - rb * rb);
  if (disc < 0) return -1;
  const double sq = std::sqrt(disc), len = std::sqrt(a);
  const double t_exit = (-b + sq) / a;
  if (t_exit <= kEps) return -1;
  double t = std::max((-b - sq) / a, kEps);
  for (int it = 0; it < 400 && t <= t_exit; ++it) {
    const double dist = torus_distance(add(o, mul(d, t)), big, small);
    if (dist < 1e-10) return t;
    t += dist / len;
  }
  return -1;
}

// L of two bars sharing the corner (-x, -y): part 0 the horizontal bar, part 1 the vertical.
std::array<std::array<V3, 2>, 2> ell_boxes(const SynthShape& s) {
  const double a = s.size[0], b = s.size[1], w = s.size[2];
  return {{{V3{-a, -b, -w}, V3{a, -b + 2 * w, w}}, {V3{-a, -b, -w}, V3{-a + 2 * w, b, w}}}};
}

// Face normal of the box [lo, hi] at p: the axis where p is relatively nearest a face.
V3 aabb_normal(V3 p, V3 lo, V3 hi) {
  int axis = 0;
  double best = 1e300;
  V3 n{0, 0, 0};
  for (int k = 0; k < 3; ++k)
    for (int side = 0; side < 2; ++side) {
      const double gap = std::abs(p[k] - (side ? hi[k] : lo[k]));
      if (gap < best) {
        best = gap;
        axis = k;
        n = {0, 0, 0};
        n[axis] = side ? 1 : -1;
      }
    }
  return n;
}

}  // namespace

Pose34 axis_angle_pose(V3 axis, double angle, V3 c) {
  axis = normalize(axis);
  const double s = std::sin(angle), co = std::cos(angle), t = 1 - co;
  const double x = axis[0], y = axis[1], z = axis[2];
  return {t * x * x + co,     t * x * y - s * z, t * x * z + s * y, c[0],
          t * x * y + s * z, t * y * y + co,     t * y * z - s * x, c[1],
          t * x * z - s * y, t * y * z + s * x, t * z * z + co,     c[2]};
}

ShapeHit intersect_shape(const SynthShape& s, V3 o, V3 d) {
  const V3& z = s.size;
  switch (s.kind) {
    case SynthShapeKind::sphere:
      return {hit_sphere(o, d, {0, 0, 0}, z[0]), 0};
    case SynthShapeKind::box:
      return {hit_aabb(o, d, {-z[0], -z[1], -z[2]}, {z[0], z[1], z[2]}), 0};
    case SynthShapeKind::cylinder:
    case SynthShapeKind::disc:
    case SynthShapeKind::rod:
      return hit_cylinder(o, d, z[0], z[1]);
    case SynthShapeKind::torus:
      return {hit_torus(o, d, z[0], z[1]), 0};
    case SynthShapeKind::dumbbell: {
      // Balls (parts 0, 1) joined by a bar along x (part 2: a y-cylinder in swapped axes).
      ShapeHit best;
      auto take = [&](ShapeHit h) {
        if (h.t > 0 && (best.t < 0 || h.t < best.t)) best = h;
      };
      take({hit_sphere(o, d, {-z[1], 0, 0}, z[0]), 0});
      take({hit_sphere(o, d, {z[1], 0, 0}, z[0]), 1});
      take({hit_cylinder(swap_xy(o), swap_xy(d), z[2], z[1]).t, 2});
      return best;
    }
    case SynthShapeKind::ell: {
      ShapeHit best;
      const auto boxes = ell_boxes(s);
      for (int k = 0; k < 2; ++k) {
        const double t = hit_aabb(o, d, boxes[k][0], boxes[k][1]);
        if (t > 0 && (best.t < 0 || t < best.t)) best = {t, k};
      }
      return best;
    }
  }
  throw Error("synthetic shape: unknown kind");
}

V3 shape_normal(const SynthShape& s, V3 p, int part) {
  const V3& z = s.size;
  switch (s.kind) {
    case SynthShapeKind::sphere:
      return normalize(p);
    case SynthShapeKind::box: {
      // The face is the axis where |p| is largest relative to the half size; a cube compares
      // |p| itself (no division), as the fixed presets always did, so ties break the same.
      const bool cube = z[0] == z[1] && z[1] == z[2];
      int axis = 0;
      for (int k = 1; k < 3; ++k)
        if (cube ? std::abs(p[k]) > std::abs(p[axis])
                 : std::abs(p[k]) / z[k] > std::abs(p[axis]) / z[axis])
          axis = k;
      V3 n{0, 0, 0};
      n[axis] = p[axis] > 0 ? 1 : -1;
      return n;
    }
    case SynthShapeKind::cylinder:
    case SynthShapeKind::disc:
    case SynthShapeKind::rod:
      if (part == 1) return {0, p[1] > 0 ? 1.0 : -1.0, 0};
      return normalize({p[0], 0, p[2]});
    case SynthShapeKind::torus: {
      const double rho = std::sqrt(p[0] * p[0] + p[2] * p[2]);
      const double k = rho > 1e-12 ? 1 - z[0] / rho : 0;
      return normalize({p[0] * k, p[1], p[2] * k});
    }
    case SynthShapeKind::dumbbell:
      if (part == 0) return normalize(sub(p, {-z[1], 0, 0}));
      if (part == 1) return normalize(sub(p, {z[1], 0, 0}));
      if (std::abs(std::abs(p[0]) - z[1]) < 1e-9) return {p[0] > 0 ? 1.0 : -1.0, 0, 0};
      return normalize({0, p[1], p[2]});
    case SynthShapeKind::ell: {
      const auto boxes = ell_boxes(s);
      return aabb_normal(p, boxes[part][0], boxes[part][1]);
    }
  }
  throw Error("synthetic shape: unknown kind");
}

}  // namespace nova::synth

namespace nova {

const char* synth_shape_name(SynthShapeKind kind) {
  switch (kind) {
    case SynthShapeKind::sphere: return "sphere";
    case SynthShapeKind::box: return "box";
    case SynthShapeKind::cylinder: return "cylinder";
    case SynthShapeKind::torus: return "torus";
    case SynthShapeKind::disc: return "disc";
    case SynthShapeKind::rod: return "rod";
    case SynthShapeKind::dumbbell: return "dumbbell";
    case SynthShapeKind::ell: return "ell";
  }
  return "?";
}

double synth_bounding_radius(const SynthShape& s) {
  const SynthVec& z = s.size;
  switch (s.kind) {
    case SynthShapeKind::sphere: return z[0];
    case SynthShapeKind::box: return std::sqrt(synth::dot(z, z));
    case SynthShapeKind::cylinder:
    case SynthShapeKind::disc:
    case SynthShapeKind::rod: return std::sqrt(z[0] * z[0] + z[1] * z[1]);
    case SynthShapeKind::torus: return z[0] + z[1];
    case SynthShapeKind::dumbbell: return z[1] + z[0];
    case SynthShapeKind::ell: return std::sqrt(synth::dot(z, z));
  }
  return 0;
}

double synth_intersect(const SynthShape& shape, const SynthVec& o, const SynthVec& d) {
  return synth::intersect_shape(shape, o, d).t;
}

}  // namespace nova

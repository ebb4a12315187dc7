// The analytic world of the synthetic scenes (see include/nova/synth.hpp): geometry, motion,
// procedural textures and a one-ray-per-pixel ray tracer. Plain double arithmetic in a fixed
// order, one thread, so equal inputs give equal bytes.
#include <algorithm>
#include <cmath>
#include <random>

#include "nova/error.hpp"
#include "nova/synth.hpp"

namespace nova {
namespace {

using V3 = std::array<double, 3>;
constexpr double kPi = 3.14159265358979323846;
constexpr double kWallZ = -6.0, kFloorY = -1.4;
constexpr double kSphereRadius = 0.42, kBoxHalf = 0.3;

V3 add(V3 a, V3 b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
V3 sub(V3 a, V3 b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
V3 mul(V3 a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
double dot(V3 a, V3 b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
V3 cross(V3 a, V3 b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
V3 normalize(V3 v) { return mul(v, 1.0 / std::sqrt(dot(v, v))); }
V3 mix(V3 a, V3 b, double t) { return add(mul(a, 1 - t), mul(b, t)); }

// Rotation about a unit axis (Rodrigues), row-major 3x3 inside a Pose34 with translation c.
Pose34 axis_angle_pose(V3 axis, double angle, V3 c) {
  axis = normalize(axis);
  const double s = std::sin(angle), co = std::cos(angle), t = 1 - co;
  const double x = axis[0], y = axis[1], z = axis[2];
  return {t * x * x + co,     t * x * y - s * z, t * x * z + s * y, c[0],
          t * x * y + s * z, t * y * y + co,     t * y * z - s * x, c[1],
          t * x * z - s * y, t * y * z + s * x, t * z * z + co,     c[2]};
}

// World -> local for a rigid pose: R^T (p - c); directions: R^T d.
V3 to_local_point(const Pose34& m, V3 p) {
  const V3 q{p[0] - m[3], p[1] - m[7], p[2] - m[11]};
  return {m[0] * q[0] + m[4] * q[1] + m[8] * q[2], m[1] * q[0] + m[5] * q[1] + m[9] * q[2],
          m[2] * q[0] + m[6] * q[1] + m[10] * q[2]};
}
V3 to_local_dir(const Pose34& m, V3 d) {
  return {m[0] * d[0] + m[4] * d[1] + m[8] * d[2], m[1] * d[0] + m[5] * d[1] + m[9] * d[2],
          m[2] * d[0] + m[6] * d[1] + m[10] * d[2]};
}
V3 to_world_dir(const Pose34& m, V3 d) {
  return {m[0] * d[0] + m[1] * d[1] + m[2] * d[2], m[4] * d[0] + m[5] * d[1] + m[6] * d[2],
          m[8] * d[0] + m[9] * d[1] + m[10] * d[2]};
}

Camera look_at(const SynthPreset& p, V3 pos, V3 target) {
  const V3 back = normalize(sub(pos, target));
  const V3 right = normalize(cross({0, 1, 0}, back));
  const V3 up = cross(back, right);
  Camera c;
  c.width = p.width;
  c.height = p.height;
  c.fx = c.fy = p.focal;
  c.cx = 0.5 * p.width;
  c.cy = 0.5 * p.height;
  c.c2w = {right[0], up[0], back[0], pos[0], right[1], up[1], back[1], pos[1],
           right[2], up[2], back[2], pos[2]};
  return c;
}

// Nearest positive root of |o + t d - c|^2 = r^2 (d need not be unit length).
double hit_sphere(V3 o, V3 d, V3 c, double r) {
  const V3 oc = sub(o, c);
  const double a = dot(d, d), b = dot(oc, d), cc = dot(oc, oc) - r * r;
  const double disc = b * b - a * cc;
  if (disc < 0) return -1;
  const double sq = std::sqrt(disc);
  double t = (-b - sq) / a;
  if (t <= 1e-9) t = (-b + sq) / a;
  return t > 1e-9 ? t : -1;
}

// Ray against an axis-aligned cube of half size h in local coordinates (slab method).
double hit_box(V3 o, V3 d, double h) {
  double t0 = -1e300, t1 = 1e300;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(d[k]) < 1e-15) {
      if (o[k] < -h || o[k] > h) return -1;
      continue;
    }
    double a = (-h - o[k]) / d[k], b = (h - o[k]) / d[k];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  }
  if (t0 > t1 || t1 <= 1e-9) return -1;
  return t0 > 1e-9 ? t0 : t1;
}

double shade(V3 n) {
  static const V3 light = normalize({0.35, 0.8, 0.5});
  return 0.6 + 0.4 * std::max(0.0, dot(n, light));
}

uint8_t to8(double v) { return static_cast<uint8_t>(std::lround(std::clamp(v, 0.0, 1.0) * 255.0)); }

}  // namespace

SynthPreset synth_preset(const std::string& name) {
  SynthPreset p;
  p.name = name;
  if (name == "tiny") {
    p.width = 64;
    p.height = 48;
    p.frames = 10;
  } else if (name == "default") {
    p.width = 160;
    p.height = 120;
    p.frames = 24;
  } else {
    throw Error("unknown synthetic preset '" + name + "' (use tiny or default)");
  }
  p.focal = 1.1 * p.width;  // about 49 degrees horizontal field of view
  return p;
}

SynthWorld::SynthWorld(const std::string& preset, uint32_t seed) : preset_(synth_preset(preset)) {
  // Our own uniform mapping: std::uniform_real_distribution is not specified bit-exactly.
  std::mt19937 rng(seed);
  for (double& r : rnd_) r = double(rng() >> 8) * (1.0 / 16777216.0);
}

Camera SynthWorld::camera(int frame) const {
  const int n = preset_.frames;
  const double u = n > 1 ? double(frame) / (n - 1) : 0.0;
  const V3 pos{-0.35 + 0.7 * u + 0.04 * (rnd_[20] - 0.5) * std::sin(7.0 * frame),
               0.06 * std::sin(kPi * u + 2 * kPi * rnd_[21]), 0.15 * u};
  const V3 target{0.2 * (rnd_[22] - 0.5), -0.15, -5.0};
  return look_at(preset_, pos, target);
}

Camera SynthWorld::heldout_camera(int index) const {
  const V3 target{0.2 * (rnd_[22] - 0.5), -0.15, -5.0};
  if (index == 1) return look_at(preset_, {0.0, 0.35, 0.05}, target);
  if (index == 2) return look_at(preset_, {0.15, -0.3, -0.1}, target);
  throw Error("held-out camera " + std::to_string(index) + " does not exist (1 or 2)");
}

Pose34 SynthWorld::object_pose(int object, double time) const {
  const double u = 0.5 * (time + 1.0);
  if (object == 1) {
    const V3 c{-1.0 + 1.8 * u + 0.2 * (rnd_[8] - 0.5),
               -0.35 + 0.22 * std::sin(2 * kPi * (u + rnd_[9])), -3.6};
    return axis_angle_pose({0.2, 1.0, 0.1}, 3.0 * u + 2 * kPi * rnd_[10], c);
  }
  if (object == 2) {
    const V3 c{0.55 - 1.0 * u + 0.2 * (rnd_[11] - 0.5),
               0.4 + 0.1 * std::cos(2 * kPi * (u + rnd_[12])), -2.3 - 0.25 * u};
    return axis_angle_pose({0.4, 1.0, 0.3}, 2.5 * u + 2 * kPi * rnd_[13], c);
  }
  throw Error("synthetic object " + std::to_string(object) + " does not exist (1 or 2)");
}

SynthRender SynthWorld::render(const Camera& camera, double time) const {
  return render_instances(camera, true, {{1, object_pose(1, time)}, {2, object_pose(2, time)}});
}

SynthRender SynthWorld::render_instances(const Camera& cam, bool background,
                                         const std::vector<SynthInstance>& instances) const {
  const double* r = rnd_;
  const V3 static_centre{1.3 + 0.2 * (r[14] - 0.5), -0.75, -4.4};
  const double static_radius = 0.65;
  SynthRender out;
  out.rgb = Image8(cam.width, cam.height, 3);
  for (int k = 0; k <= kObjects; ++k) out.masks.emplace_back(cam.width, cam.height, 1);
  out.depth.width = cam.width;
  out.depth.height = cam.height;
  out.depth.data.assign(size_t(cam.width) * cam.height, 0.0f);
  const V3 o{cam.c2w[3], cam.c2w[7], cam.c2w[11]};

  for (int j = 0; j < cam.height; ++j) {
    for (int i = 0; i < cam.width; ++i) {
      // camera.hpp: direction ((i - cx) / fx, -(j - cy) / fy, -1); t is then the z-depth.
      const V3 dc{(i - cam.cx) / cam.fx, -(j - cam.cy) / cam.fy, -1.0};
      const V3 d{cam.c2w[0] * dc[0] + cam.c2w[1] * dc[1] + cam.c2w[2] * dc[2],
                 cam.c2w[4] * dc[0] + cam.c2w[5] * dc[1] + cam.c2w[6] * dc[2],
                 cam.c2w[8] * dc[0] + cam.c2w[9] * dc[1] + cam.c2w[10] * dc[2]};
      double best = 1e300;
      int owner = -1;  // 0 background, k object
      V3 colour{0, 0, 0};

      if (background) {
        if (d[2] < 0) {
          const double t = (kWallZ - o[2]) / d[2];
          if (t > 1e-9 && t < best) {
            const V3 p = add(o, mul(d, t));
            const double x = p[0], y = p[1];
            const V3 alb{0.55 + 0.25 * std::sin(2 * kPi * (0.6 * x + r[0])) *
                                    std::cos(2 * kPi * (0.45 * y + r[1])) +
                             0.1 * std::sin(2 * kPi * (1.3 * y + 0.5 * x + r[2])),
                         0.5 + 0.25 * std::sin(2 * kPi * (0.5 * y + r[3])) +
                             0.12 * std::cos(2 * kPi * (1.1 * x + r[4])),
                         0.45 + 0.25 * std::cos(2 * kPi * (0.5 * x - 0.8 * y + r[5]))};
            best = t;
            owner = 0;
            colour = mul(alb, shade({0, 0, 1}));
          }
        }
        if (d[1] < 0) {
          const double t = (kFloorY - o[1]) / d[1];
          if (t > 1e-9 && t < best) {
            const V3 p = add(o, mul(d, t));
            const double s = std::tanh(3.0 * std::sin(kPi * (1.2 * p[0] + r[6])) *
                                       std::sin(kPi * (1.2 * p[2] + r[7])));
            best = t;
            owner = 0;
            colour = mul(mix({0.3, 0.35, 0.45}, {0.8, 0.72, 0.55}, 0.5 + 0.5 * s), shade({0, 1, 0}));
          }
        }
        const double ts = hit_sphere(o, d, static_centre, static_radius);
        if (ts > 0 && ts < best) {
          const V3 n = normalize(sub(add(o, mul(d, ts)), static_centre));
          const double s = 0.5 + 0.5 * std::sin(7.0 * std::atan2(n[2], n[0]) + 2 * kPi * r[15]);
          best = ts;
          owner = 0;
          colour = mul(mix({0.45, 0.2, 0.55}, {0.35, 0.7, 0.45}, s), shade(n));
        }
      }

      for (const auto& inst : instances) {
        const V3 ol = to_local_point(inst.pose, o), dl = to_local_dir(inst.pose, d);
        if (inst.object == 1) {
          const double t = hit_sphere(ol, dl, {0, 0, 0}, kSphereRadius);
          if (t > 0 && t < best) {
            const V3 nl = normalize(add(ol, mul(dl, t)));
            const double lon = std::atan2(nl[2], nl[0]), lat = std::asin(std::clamp(nl[1], -1.0, 1.0));
            const double m = 0.5 + 0.5 * std::tanh(4.0 * std::sin(3.0 * lon + 2 * kPi * r[16]));
            const V3 alb = mul(mix({0.85, 0.15, 0.1}, {0.95, 0.85, 0.2}, m),
                               0.75 + 0.25 * std::cos(6.0 * lat));
            best = t;
            owner = 1;
            colour = mul(alb, shade(to_world_dir(inst.pose, nl)));
          }
        } else if (inst.object == 2) {
          const double t = hit_box(ol, dl, kBoxHalf);
          if (t > 0 && t < best) {
            const V3 p = add(ol, mul(dl, t));
            // The face is the axis where |p| is largest; its two other coordinates texture it.
            int axis = 0;
            for (int k = 1; k < 3; ++k)
              if (std::abs(p[k]) > std::abs(p[axis])) axis = k;
            V3 nl{0, 0, 0};
            nl[axis] = p[axis] > 0 ? 1 : -1;
            const double a = p[(axis + 1) % 3] / kBoxHalf, b = p[(axis + 2) % 3] / kBoxHalf;
            const double s = std::tanh(3.0 * std::sin(kPi * (a + r[17])) * std::sin(kPi * (b + r[18])));
            const V3 base = axis == 1 ? V3{0.1, 0.45, 0.9} : V3{0.15, 0.75, 0.35};
            best = t;
            owner = 2;
            colour = mul(mix(base, {0.92, 0.92, 0.88}, 0.5 + 0.4 * s), shade(to_world_dir(inst.pose, nl)));
          }
        } else {
          throw Error("synthetic object " + std::to_string(inst.object) + " does not exist");
        }
      }

      if (owner < 0) continue;  // nothing hit: black, depth 0, no mask
      for (int c = 0; c < 3; ++c) out.rgb.at(i, j, c) = to8(colour[c]);
      out.masks[owner].at(i, j) = 255;
      out.depth.data[size_t(j) * cam.width + i] = static_cast<float>(best);
    }
  }
  return out;
}

}  // namespace nova

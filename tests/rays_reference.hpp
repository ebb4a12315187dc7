#pragma once
// Float64 host references of the ray ops (kernels/sampling.cl), written from the conventions
// (camera.hpp, the reference code's ndc_rays and stratified sampling) and independent of the
// kernels. Shared by test_rays.cpp and the op table (op_table_render.cpp).
#include <array>
#include <cmath>
#include <vector>

#include "harness.hpp"
#include "nova/sampling/camera.hpp"
#include "nova/model/compose_spec.hpp"
#include "nova/graph/executor.hpp"
#include "nova/sampling/rays.hpp"

namespace nova::test {

// A camera at `position` rotated by `angle` about y then `tilt` about x (c2w, OpenGL axes).
inline Camera make_camera(double f, int w, int h, std::array<double, 3> position, double angle, double tilt) {
  Camera c;
  c.width = w;
  c.height = h;
  c.fx = c.fy = f;
  c.cx = w / 2.0;
  c.cy = h / 2.0;
  const double ca = std::cos(angle), sa = std::sin(angle), ct = std::cos(tilt), st = std::sin(tilt);
  // R = Ry(angle) * Rx(tilt)
  const double R[3][3] = {{ca, sa * st, sa * ct}, {0, ct, -st}, {-sa, ca * st, ca * ct}};
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) c.c2w[r * 4 + k] = static_cast<float>(R[r][k]);
    c.c2w[r * 4 + 3] = static_cast<float>(position[r]);
  }
  c.fx = c.fy = static_cast<float>(f);
  return c;
}

struct RefRay {
  std::array<double, 3> o, d, view;
};

// Straight from camera.hpp and the reference's ndc_rays (near plane `near`).
inline RefRay ref_ray(const Camera& c, double i, double j, bool ndc, double near) {
  const double cam[3] = {(i - c.cx) / c.fx, -(j - c.cy) / c.fy, -1.0};
  RefRay r;
  for (int k = 0; k < 3; ++k) {
    r.d[k] = c.rotation(k, 0) * cam[0] + c.rotation(k, 1) * cam[1] + c.rotation(k, 2) * cam[2];
    r.o[k] = c.position(k);
  }
  const double n = std::sqrt(r.d[0] * r.d[0] + r.d[1] * r.d[1] + r.d[2] * r.d[2]);
  for (int k = 0; k < 3; ++k) r.view[k] = r.d[k] / n;
  if (ndc) {
    const double W = 2 * c.cx, H = 2 * c.cy, focal = c.fx;
    const double t = -(near + r.o[2]) / r.d[2];
    std::array<double, 3> o;
    for (int k = 0; k < 3; ++k) o[k] = r.o[k] + t * r.d[k];
    const auto& d = r.d;
    r.o = {-1 / (W / (2 * focal)) * o[0] / o[2], -1 / (H / (2 * focal)) * o[1] / o[2], 1 + 2 * near / o[2]};
    r.d = {-1 / (W / (2 * focal)) * (d[0] / d[2] - o[0] / o[2]),
           -1 / (H / (2 * focal)) * (d[1] / d[2] - o[1] / o[2]), -2 * near / o[2]};
  }
  return r;
}

inline std::vector<float> random_pixels(size_t R, int w, int h, unsigned seed) {
  auto u = random_floats(R * 2, 0, 1, seed);
  for (size_t r = 0; r < R; ++r) {
    u[2 * r] = std::floor(u[2 * r] * w);
    u[2 * r + 1] = std::floor(u[2 * r + 1] * h);
  }
  return u;
}

// The reference's stratified depths: linspace(near, far, S); with jitter u, uniform between
// the midpoints to the neighbours.
inline std::vector<double> ref_depths(size_t R, size_t S, double near, double far, const std::vector<float>& u) {
  std::vector<double> z(R * S);
  for (size_t r = 0; r < R; ++r) {
    std::vector<double> t(S);
    for (size_t i = 0; i < S; ++i) t[i] = near * (1 - double(i) / (S - 1)) + far * double(i) / (S - 1);
    for (size_t i = 0; i < S; ++i) {
      if (u.empty()) {
        z[r * S + i] = t[i];
        continue;
      }
      const double lower = i > 0 ? 0.5 * (t[i - 1] + t[i]) : t[i];
      const double upper = i + 1 < S ? 0.5 * (t[i] + t[i + 1]) : t[i];
      z[r * S + i] = lower + (upper - lower) * u[r * S + i];
    }
  }
  return z;
}

// One point seen by a placed instance: world-to-object map m (3x4 row-major); for NDC points
// NDC -> world -> map -> NDC with the constants ax = -fx / cx, ay = -fy / cy and the near plane.
inline std::array<double, 3> ref_instance_point(const std::array<double, 12>& m,
                                                std::array<double, 3> p, bool ndc, double ax,
                                                double ay, double near) {
  if (ndc) {
    const double pz = 2.0 * near / (p[2] - 1.0);
    p[0] = p[0] * pz / ax;
    p[1] = p[1] * pz / ay;
    p[2] = pz;
  }
  std::array<double, 3> r;
  for (int k = 0; k < 3; ++k)
    r[k] = m[k * 4] * p[0] + m[k * 4 + 1] * p[1] + m[k * 4 + 2] * p[2] + m[k * 4 + 3];
  if (ndc) {
    const double z = r[2];
    r[0] = ax * r[0] / z;
    r[1] = ay * r[1] / z;
    r[2] = 1.0 + 2.0 * near / z;
  }
  return r;
}

// instance_points on `rows` points (drawn from `seed`) and 3 placed instances, NDC and metric,
// against ref_instance_point. Points are kept at world depth in [-8, -1.2] (q_z <= 0.67): the
// kernel works in float32 through a division by (q_z - 1) and back, which there loses < 1e-5
// relative, so 1e-4 absolute on NDC values in [-2, 2].
inline void check_instance_points(Runtime& rt, size_t rows, unsigned seed) {
  const size_t B = 3;
  const double ax = -1.7, ay = -2.2, near = 1.0;
  const auto rnd = random_floats(rows * 3, -0.6f, 0.6f, seed);
  std::vector<float> q(rows * 3);
  for (size_t i = 0; i < rows; ++i) {
    const double z = -1.2 - 6.8 * (0.5 + rnd[i * 3 + 2]) / 1.2;  // world depth in [-8, -1.2]
    q[i * 3] = static_cast<float>(ax * (rnd[i * 3] * 2.0));
    q[i * 3 + 1] = static_cast<float>(ay * (rnd[i * 3 + 1] * 2.0));
    q[i * 3 + 2] = static_cast<float>(1.0 + 2.0 * near / z);
  }
  std::vector<float> xf;
  std::vector<std::array<double, 12>> m;
  for (size_t b = 0; b < B; ++b) {
    ComposeInstance inst;
    inst.rotate_deg = {10.0 * b, -20.0 + 5.0 * b, 3.0};
    inst.translate = {0.1 * b, -0.05, 0.2 - 0.1 * b};
    inst.pivot = {0.0, 0.1, -2.0};
    m.push_back(instance_transform(inst));
    for (double x : m.back()) xf.push_back(static_cast<float>(x));
  }
  for (bool ndc : {true, false}) {
    Graph g;
    Tensor pos = g.input("positions", Shape{rows, 3}), tr = g.input("transforms", Shape{B, 12});
    InstanceOptions o;
    o.ndc = ndc;
    o.ax = static_cast<float>(ax);
    o.ay = static_cast<float>(ay);
    Tensor out = instance_points(pos, tr, o);
    g.keep(out);
    Executor ex(rt, g, guarded_options());
    ex.set(pos, q);
    ex.set(tr, xf);
    ex.forward();
    std::vector<double> want;
    for (size_t b = 0; b < B; ++b)
      for (size_t i = 0; i < rows; ++i) {
        const auto r = ref_instance_point(m[b], {q[i * 3], q[i * 3 + 1], q[i * 3 + 2]}, ndc,
                                          ax, ay, near);
        want.insert(want.end(), r.begin(), r.end());
      }
    expect_close(ex.get(out), want, 1e-4, 1e-4, ndc ? "instance_points ndc" : "instance_points metric");
  }
}

}  // namespace nova::test

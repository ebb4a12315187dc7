#pragma once
// A pinhole camera, the one convention every part of nova shares (readers, the synthetic
// generator, ray generation, rendering).
//
// - c2w is the 3x4 camera-to-world matrix, row-major, with OpenGL/NeRF axes: camera x right,
//   y up, and the camera looks along -z. (LLFF's poses_bounds.npy stores [down, right, back];
//   readers convert, as the reference code does.)
// - Pixel (i, j) (column i, row j from the top) has the camera-space direction
//   ((i - cx) / fx, -(j - cy) / fy, -1): the reference implementations' convention, with no
//   half-pixel offset, so that PSNRs are comparable with theirs.
// - Forward-facing scenes are rendered in normalised device coordinates with the near plane
//   at 1 (Scene::ndc), which assumes fx == fy and the principal point at the image centre,
//   as the reference's ndc_rays does.
#include <algorithm>
#include <array>
#include <cmath>

namespace nova {

struct Camera {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::array<double, 12> c2w{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};

  double rotation(int r, int c) const { return c2w[r * 4 + c]; }
  double position(int r) const { return c2w[r * 4 + 3]; }
};

// The world direction pixel (x, y) looks along, at unit camera-space depth: the camera's axes
// times ((x - cx) / fx, -(y - cy) / fy, -1).
inline std::array<double, 3> camera_ray_direction(const Camera& c, double x, double y) {
  const double u = (x - c.cx) / c.fx, v = -(y - c.cy) / c.fy;
  std::array<double, 3> d{};
  for (int k = 0; k < 3; ++k) d[k] = c.rotation(k, 0) * u + c.rotation(k, 1) * v - c.rotation(k, 2);
  return d;
}

// The world point of pixel (x, y) at camera-space depth `depth` (the distance along the view
// axis, -z of the camera's frame).
inline std::array<double, 3> camera_unproject(const Camera& c, double x, double y, double depth) {
  const std::array<double, 3> d = camera_ray_direction(c, x, y);
  std::array<double, 3> p{};
  for (int k = 0; k < 3; ++k) p[k] = c.position(k) + depth * d[k];
  return p;
}

// A world point's pixel (x, y) and camera-space depth; depth <= 0 behind the camera (x, y 0).
inline std::array<double, 3> camera_project(const Camera& c, const std::array<double, 3>& p) {
  double q[3]{};
  for (int k = 0; k < 3; ++k)
    for (int r = 0; r < 3; ++r) q[k] += c.rotation(r, k) * (p[r] - c.position(r));
  const double z = -q[2];
  if (z <= 1e-12) return {0, 0, z};
  return {c.cx + c.fx * q[0] / z, c.cy - c.fy * q[1] / z, z};
}

// The largest entry of |R^T R - I| for the 3x3 block R = m[r * row_stride + c] (r, c < 3):
// 0 when its columns are orthonormal (a rotation or a reflection). Readers refuse camera
// axes beyond a tolerance, as rays are built from them as unit vectors.
inline double axes_deviation(const double* m, int row_stride) {
  double worst = 0;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      double dot = 0;
      for (int r = 0; r < 3; ++r) dot += m[r * row_stride + a] * m[r * row_stride + b];
      worst = std::max(worst, std::abs(dot - (a == b ? 1.0 : 0.0)));
    }
  return worst;
}

}  // namespace nova

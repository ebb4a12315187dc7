// LLFF pose processing (see include/nova/data/llff_poses.hpp). Plain double arithmetic, no
// libraries, so the synthetic generator and the readers compute exactly the same transform.
#include "nova/data/llff_poses.hpp"

#include <algorithm>
#include <cmath>

namespace nova {
namespace {

using V3 = std::array<double, 3>;

V3 normalize(const V3& v) {
  const double n = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  return {v[0] / n, v[1] / n, v[2] / n};
}

V3 cross(const V3& a, const V3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

}  // namespace

Pose34 llff_row_to_gl(const double* row) {
  // row[r * 5 + c] is the 3x5 block; columns 0..2 are down, right, back.
  Pose34 p{};
  for (int r = 0; r < 3; ++r) {
    p[r * 4 + 0] = row[r * 5 + 1];
    p[r * 4 + 1] = -row[r * 5 + 0];
    p[r * 4 + 2] = row[r * 5 + 2];
    p[r * 4 + 3] = row[r * 5 + 3];
  }
  return p;
}

std::array<double, 15> gl_to_llff_block(const Pose34& c, double h, double w, double f) {
  std::array<double, 15> b{};
  const double hwf[3] = {h, w, f};
  for (int r = 0; r < 3; ++r) {
    b[r * 5 + 0] = -c[r * 4 + 1];  // down = -up
    b[r * 5 + 1] = c[r * 4 + 0];   // right
    b[r * 5 + 2] = c[r * 4 + 2];   // back
    b[r * 5 + 3] = c[r * 4 + 3];
    b[r * 5 + 4] = hwf[r];
  }
  return b;
}

double percentile_linear(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  if (v.empty()) return 0;
  const double pos = q / 100.0 * double(v.size() - 1);
  const size_t lo = static_cast<size_t>(std::floor(pos));
  const size_t hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - double(lo)) * (v[hi] - v[lo]);
}

Pose34 pose_multiply(const Pose34& a, const Pose34& b) {
  Pose34 r{};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 4; ++j) {
      double s = j == 3 ? a[i * 4 + 3] : 0.0;
      for (int k = 0; k < 3; ++k) s += a[i * 4 + k] * b[k * 4 + j];
      r[i * 4 + j] = s;
    }
  }
  return r;
}

Pose34 pose_inverse(const Pose34& m) {
  // [R | t]^-1 = [R^T | -R^T t]; the average pose is orthonormal by construction.
  Pose34 r{};
  for (int i = 0; i < 3; ++i) {
    double s = 0;
    for (int k = 0; k < 3; ++k) {
      r[i * 4 + k] = m[k * 4 + i];
      s += m[k * 4 + i] * m[k * 4 + 3];
    }
    r[i * 4 + 3] = -s;
  }
  return r;
}

Pose34 WorldTransform::apply(const Pose34& c2w) const {
  Pose34 scaled = c2w;
  for (int r = 0; r < 3; ++r) scaled[r * 4 + 3] *= scale;
  return pose_multiply(recenter, scaled);
}

std::array<double, 3> WorldTransform::apply_point(const std::array<double, 3>& p) const {
  std::array<double, 3> o{};
  for (int r = 0; r < 3; ++r)
    o[r] = recenter[r * 4 + 0] * p[0] * scale + recenter[r * 4 + 1] * p[1] * scale +
           recenter[r * 4 + 2] * p[2] * scale + recenter[r * 4 + 3];
  return o;
}

std::array<double, 3> WorldTransform::apply_direction(const std::array<double, 3>& d) const {
  std::array<double, 3> o{};
  for (int r = 0; r < 3; ++r)
    o[r] = recenter[r * 4 + 0] * d[0] + recenter[r * 4 + 1] * d[1] + recenter[r * 4 + 2] * d[2];
  return o;
}

WorldTransform llff_world_transform(const std::vector<Pose34>& raw, const std::vector<double>& near,
                                    double bd_factor, bool recenter) {
  WorldTransform t;
  if (bd_factor > 0) t.scale = 1.0 / (percentile_linear(near, 5.0) * bd_factor);
  if (!recenter || raw.empty()) return t;
  V3 centre{0, 0, 0}, back{0, 0, 0}, up{0, 0, 0};
  for (const auto& p : raw) {
    for (int r = 0; r < 3; ++r) {
      centre[r] += p[r * 4 + 3] * t.scale;
      back[r] += p[r * 4 + 2];
      up[r] += p[r * 4 + 1];
    }
  }
  for (auto& c : centre) c /= double(raw.size());
  // viewmatrix(z, up, pos): z = normalize(back), x = normalize(up x z), y = normalize(z x x)
  const V3 z = normalize(back);
  const V3 x = normalize(cross(up, z));
  const V3 y = normalize(cross(z, x));
  const Pose34 avg{x[0], y[0], z[0], centre[0], x[1], y[1], z[1], centre[1],
                   x[2], y[2], z[2], centre[2]};
  t.recenter = pose_inverse(avg);
  return t;
}

}  // namespace nova

#pragma once
// Vector helpers and shape geometry shared by the synthetic world's tracer and sampler.
// Plain double arithmetic in a fixed order: the fixed presets' bytes depend on it.
#include <cmath>

#include "nova/data/synth.hpp"

namespace nova::synth {

using V3 = SynthVec;
constexpr double kPi = 3.14159265358979323846;

inline V3 add(V3 a, V3 b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
inline V3 sub(V3 a, V3 b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
inline V3 mul(V3 a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
inline double dot(V3 a, V3 b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline V3 cross(V3 a, V3 b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline V3 normalize(V3 v) { return mul(v, 1.0 / std::sqrt(dot(v, v))); }
inline V3 mix(V3 a, V3 b, double t) { return add(mul(a, 1 - t), mul(b, t)); }

// Rotation about an axis (Rodrigues), row-major 3x3 inside a Pose34 with translation c.
Pose34 axis_angle_pose(V3 axis, double angle, V3 c);

// A hit of a shape: ray parameter and which part (a face group) was hit, so that the normal
// can be taken from the part rather than guessed from the point.
struct ShapeHit {
  double t = -1;
  int part = 0;
};
ShapeHit intersect_shape(const SynthShape& s, V3 o, V3 d);
// Outward unit normal at a surface point p (shape frame) of the given part.
V3 shape_normal(const SynthShape& s, V3 p, int part);

}  // namespace nova::synth

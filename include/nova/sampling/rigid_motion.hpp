#pragma once
// Learned rigid motion of the object NeRFs: each object is one shape in a canonical space of
// its own, and a trajectory maps every time's scene into that space, so that every frame's
// camera sees, and trains, the same shape (a field of (x, y, z, t) sees each time from one
// camera only). Per object and frame the motion is 6 numbers, Euler angles (a_x, a_y, a_z;
// R = Rz Ry Rx) and a translation tau; a sample x of time t maps to
//   y = R(a(t)) (x - tau(t)) + q,
// (a, tau)(t) linear between the two frames around t (frame i at t = 2 i / F - 1, clamped to
// the first and last), q the object's pivot, the mean of its translations: where its
// canonical shape sits in the scene. q is a function of the trajectory, not a parameter of
// its own: a free pivot is redundant with the translations and drifted out of the encoded box.
// Parameter layout [K, F, 6] ([F, 6] for K = 1), one row per frame.
//
// In NDC (forward-facing scenes) x is a sample's world position (NDC -> world as
// instance_points), and y goes back to NDC for the encoding: a rigid motion is rigid in the
// world, not in NDC.
#include <array>
#include <vector>

#include "nova/graph/graph.hpp"

namespace nova {

enum class ObjectMotion {
  None,   // the paper's object field of (x, y, z, t)
  Rigid,  // a canonical field of (x, y, z) moved by a learned per-frame rigid motion
};
const char* object_motion_name(ObjectMotion m);  // "none", "rigid"

struct MotionOptions {
  int frames = 1;       // F: frames of the trajectory (the scene's time axis)
  bool ndc = false;     // positions are NDC (RayGeometry::ndc) and the motion acts in world
  float ax = -1.0f, ay = -1.0f, ndc_near = 1.0f;
};

// The motion parameter "objects.motion" of `objects` objects (zeros: every frame at the pivot's
// origin; the trainer sets it from the masks before the first joint step).
Tensor motion_parameter(Graph& g, int objects, int frames);

// positions [B, M, 3] (or [M, 3]; data), times [B, 1] (data), motion [B, F, 6] (or [F, 6])
// -> canonical positions of the same shape as positions. Differentiable in the motion (per
// frame, by the interpolation weights, and through the pivot); with `differentiable`
// false a forward only, whose output takes no gradient (what a packing decision reads).
Tensor rigid_motion(Tensor positions, Tensor times, Tensor motion, const MotionOptions& options,
                    bool differentiable = true);

// Smoothness of the trajectories: mean over objects of sum_f |P[f-1] - 2 P[f] + P[f+1]|^2 /
// (F - 2) (second differences of the per-frame rows; 0 for F < 3). A scalar.
Tensor motion_smoothness(Tensor motion, int frames);

// ---- The same maps on the host, in double (the float64 reference of the tests, and what the
// compositor and the initialisation use) ----

using Vec3 = std::array<double, 3>;
using Mat3 = std::array<double, 9>;    // row-major
using Mat34 = std::array<double, 12>;  // row-major [R | t]: x -> R x + t

// R = Rz(a[2]) Ry(a[1]) Rx(a[0]), angles in radians (the composition spec's rotate= in degrees
// is the same convention: euler_xyz_deg_to_matrix).
Mat3 euler_xyz_to_matrix(const Vec3& angles);
// Its inverse: of the two Euler solutions of `r` and their 2 pi shifts, the one nearest to
// `near` (so that a trajectory's angles change smoothly).
Vec3 matrix_to_euler_xyz(const Mat3& r, const Vec3& near);

// The rotation by |w| radians about w / |w| (Rodrigues); the identity for w = 0.
Mat3 axis_angle_to_matrix(const Vec3& w);
// Its inverse for a rotation matrix: w with |w| in [0, pi] (at pi either of the two axes).
Vec3 matrix_to_axis_angle(const Mat3& r);

// The rigid map that turns by `r` about `pivot` and carries the pivot onto `destination`.
Mat34 rigid_about(const Mat3& r, const Vec3& pivot, const Vec3& destination);

// Rigid 3x4 maps: the inverse [R^T | -R^T t], a after b (x -> a(b(x))), and a point moved.
Mat34 invert_rigid(const Mat34& m);
Mat34 compose_rigid(const Mat34& a, const Mat34& b);
Vec3 apply_rigid(const Mat34& m, const Vec3& x);

// The 6 motion numbers of one object at time t from its [F, 6] rows (row-major floats).
std::array<double, 6> motion_at(const float* rows, int frames, double t);
// The pivot q of the same rows: the mean of their translations.
Vec3 motion_pivot(const float* rows, int frames);

// The world -> canonical map at time t (R | q - R tau): what a composition instance composes
// with its placement.
Mat34 motion_matrix(const float* rows, int frames, double t);

// World point x at time t -> canonical (y = R (x - tau) + q), and back.
Vec3 motion_to_canonical(const float* rows, int frames, double t, const Vec3& x);
Vec3 motion_from_canonical(const float* rows, int frames, double t, const Vec3& y);

}  // namespace nova

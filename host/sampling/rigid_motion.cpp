// rigid_motion and motion_smoothness (motion.hpp; kernels/rigid_motion.cl), and the host maps.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "nova/runtime/error.hpp"
#include "nova/graph/executor.hpp"
#include "nova/sampling/rigid_motion.hpp"
#include "nova/runtime/runtime.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

constexpr size_t kMotionCols = 6;
constexpr size_t kRowGradCols = 9;  // per row: angles, translation, pivot

class RigidMotionOp final : public Op {
 public:
  RigidMotionOp(size_t nets, size_t rows, const MotionOptions& o, bool differentiable)
      : nets_(nets), rows_(rows), o_(o), differentiable_(differentiable) {}
  std::string type() const override { return "rigid_motion"; }

  void forward(ExecContext& ctx) override {
    const size_t rows = ctx.in_rows(0, rows_);
    if (rows == 0) return;
    ctx.launch("rigid_motion", "rigid_motion_forward")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(ctx.out(0))
        .arg(detail::u32(nets_, "networks")).arg(detail::u32(rows, "rows")).arg(frames())
        .arg(static_cast<int>(o_.ndc)).arg(o_.ax).arg(o_.ay).arg(o_.ndc_near)
        .run(nets_ * rows);
  }

  void backward(ExecContext& ctx) override {
    cl_mem dm = ctx.grad_in(2);
    if (!dm) return;
    const size_t rows = ctx.in_rows(0, rows_);
    cl_mem dy = ctx.grad_out(0);
    if (!dy || rows == 0) {  // nothing downstream reads the canonical positions
      if (!ctx.accumulate_in(2)) ctx.rt.fill_zero(dm, nets_ * o_.frames * kMotionCols * sizeof(float));
      return;
    }
    ctx.launch("rigid_motion", "rigid_motion_row_grad")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(dy).arg(ctx.workspace())
        .arg(detail::u32(nets_, "networks")).arg(detail::u32(rows, "rows")).arg(frames())
        .arg(static_cast<int>(o_.ndc)).arg(o_.ax).arg(o_.ay).arg(o_.ndc_near)
        .run(nets_ * rows);
    ctx.launch("rigid_motion", "rigid_motion_param_grad")
        .arg(ctx.workspace()).arg(ctx.in(1)).arg(dm).arg(detail::u32(nets_, "networks"))
        .arg(detail::u32(rows, "rows")).arg(frames()).arg(static_cast<int>(ctx.accumulate_in(2)))
        .run(nets_ * kMotionCols);
  }

  std::vector<TensorId> saved_for_backward() const override { return inputs(); }
  bool differentiable_in(size_t index) const override { return differentiable_ && index == 2; }
  size_t workspace_bytes(Runtime&, Pass pass) const override {
    return pass == Pass::Backward ? nets_ * rows_ * kRowGradCols * sizeof(float) : 0;
  }

 private:
  unsigned frames() const { return static_cast<unsigned>(o_.frames); }
  size_t nets_, rows_;
  MotionOptions o_;
  bool differentiable_;
};

class MotionSmoothnessOp final : public Op {
 public:
  MotionSmoothnessOp(size_t nets, int frames) : nets_(nets), frames_(static_cast<unsigned>(frames)) {}
  std::string type() const override { return "motion_smoothness"; }
  void forward(ExecContext& ctx) override {
    ctx.launch("rigid_motion", "motion_smoothness_forward")
        .arg(ctx.in(0)).arg(ctx.out(0)).arg(detail::u32(nets_, "networks")).arg(frames_).run(1);
  }
  void backward(ExecContext& ctx) override {
    cl_mem dm = ctx.grad_in(0), dl = ctx.grad_out(0);
    if (!dm) return;
    const size_t n = nets_ * frames_ * kMotionCols;
    if (!dl) {
      if (!ctx.accumulate_in(0)) ctx.rt.fill_zero(dm, n * sizeof(float));
      return;
    }
    ctx.launch("rigid_motion", "motion_smoothness_backward")
        .arg(ctx.in(0)).arg(dl).arg(dm).arg(detail::u32(nets_, "networks")).arg(frames_)
        .arg(static_cast<int>(ctx.accumulate_in(0)))
        .run(n);
  }
  std::vector<TensorId> saved_for_backward() const override { return inputs(); }

 private:
  size_t nets_;
  unsigned frames_;
};

// The networks of a motion parameter [K, F, 6] or [F, 6].
size_t motion_networks(const Shape& m, int frames, const std::string& op) {
  const size_t rows = static_cast<size_t>(frames);
  if (m.rank() == 2 && m[0] == rows && m[1] == kMotionCols) return 1;
  if (m.rank() == 3 && m[1] == rows && m[2] == kMotionCols) return m[0];
  detail::bad_op(op, "motion must be [K, " + std::to_string(rows) + ", 6] or [" + std::to_string(rows) +
                         ", 6], got " + m.str());
}

}  // namespace

const char* object_motion_name(ObjectMotion m) { return m == ObjectMotion::Rigid ? "rigid" : "none"; }

Tensor motion_parameter(Graph& g, int objects, int frames) {
  if (objects < 1 || frames < 1) detail::bad_op("motion_parameter", "needs objects and frames");
  const size_t rows = static_cast<size_t>(frames);
  const Shape s = objects == 1 ? Shape{rows, kMotionCols} : Shape{static_cast<size_t>(objects), rows, kMotionCols};
  return g.parameter("objects.motion", s, Init::zeros());
}

Tensor rigid_motion(Tensor positions, Tensor times, Tensor motion, const MotionOptions& o, bool differentiable) {
  const std::string op = "rigid_motion";
  if (o.frames < 1) detail::bad_op(op, "frames must be >= 1");
  detail::require_data(op, positions);
  detail::require_data(op, times);
  const detail::Matrix3 p = detail::as_batched(positions.shape(), op);
  if (p.cols != 3) detail::bad_op(op, "positions must have 3 columns, got " + positions.shape().str());
  const size_t nets = motion_networks(motion.shape(), o.frames, op);
  if (nets != p.batch) detail::bad_op(op, "positions " + positions.shape().str() + " do not fit motion " + motion.shape().str());
  if (times.shape().numel() != nets)
    detail::bad_op(op, "times must hold one time per network, got " + times.shape().str());
  Graph& g = *positions.graph;
  Tensor y = g.activation(positions.info().name + ".canonical", positions.shape());
  g.add(std::make_unique<RigidMotionOp>(nets, p.rows, o, differentiable), {positions, times, motion}, {y});
  return y;
}

Tensor motion_smoothness(Tensor motion, int frames) {
  const size_t nets = motion_networks(motion.shape(), frames, "motion_smoothness");
  Graph& g = *motion.graph;
  Tensor y = g.activation(motion.info().name + ".smoothness", Shape{1});
  g.add(std::make_unique<MotionSmoothnessOp>(nets, frames), {motion}, {y});
  return y;
}

// ---- host maps ----

Mat3 axis_angle_to_matrix(const Vec3& w) {
  const double th = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
  if (th < 1e-12) return {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const double x = w[0] / th, y = w[1] / th, z = w[2] / th, s = std::sin(th), c = std::cos(th), t = 1 - c;
  return {t * x * x + c, t * x * y - s * z, t * x * z + s * y, t * x * y + s * z, t * y * y + c,
          t * y * z - s * x, t * x * z - s * y, t * y * z + s * x, t * z * z + c};
}

Vec3 matrix_to_axis_angle(const Mat3& r) {
  // The angle from its cosine and sine together: acos alone loses half the digits near 0 and pi.
  const Vec3 skew{r[7] - r[5], r[2] - r[6], r[3] - r[1]};  // 2 sin(th) times the axis
  const double s = 0.5 * std::sqrt(skew[0] * skew[0] + skew[1] * skew[1] + skew[2] * skew[2]);
  const double c = (r[0] + r[4] + r[8] - 1) / 2, th = std::atan2(s, c);
  if (s > 1e-4) return {th * skew[0] / (2 * s), th * skew[1] / (2 * s), th * skew[2] / (2 * s)};
  if (c > 0) return {skew[0] / 2, skew[1] / 2, skew[2] / 2};  // th < 1e-4: sin(th) = th to 1e-12
  // Near pi the skew part vanishes: the axis from the symmetric part, (R + R^T) / 2 - c I =
  // (1 - c) a a^T (its largest column), its sign from what is left of the skew part.
  const int k = r[0] >= r[4] && r[0] >= r[8] ? 0 : (r[4] >= r[8] ? 1 : 2);
  Vec3 a{};
  for (int i = 0; i < 3; ++i)
    a[static_cast<size_t>(i)] = (r[static_cast<size_t>(i * 3 + k)] + r[static_cast<size_t>(k * 3 + i)]) / 2 - (i == k ? c : 0.0);
  const double n = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
  const double sign = a[0] * skew[0] + a[1] * skew[1] + a[2] * skew[2] < 0 ? -1.0 : 1.0;
  return {sign * th * a[0] / n, sign * th * a[1] / n, sign * th * a[2] / n};
}

Mat3 euler_xyz_to_matrix(const Vec3& a) {
  const double cx = std::cos(a[0]), sx = std::sin(a[0]);
  const double cy = std::cos(a[1]), sy = std::sin(a[1]);
  const double cz = std::cos(a[2]), sz = std::sin(a[2]);
  // Rz * Ry * Rx
  return {cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx,
          sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx,
          -sy,     cy * sx,                cy * cx};
}

Vec3 matrix_to_euler_xyz(const Mat3& r, const Vec3& near) {
  using std::numbers::pi;
  // R = Rz(c) Ry(b) Rx(a): r[6] = -sin b, r[7] = cos b sin a, r[8] = cos b cos a,
  // r[0] = cos b cos c, r[3] = cos b sin c.
  const double b = std::asin(std::clamp(-r[6], -1.0, 1.0));
  const double a = std::atan2(r[7], r[8]), c = std::atan2(r[3], r[0]);
  const Vec3 solutions[2] = {{a, b, c}, {a + pi, pi - b, c + pi}};
  Vec3 best = solutions[0];
  double best_distance = 1e300;
  for (const Vec3& s : solutions) {
    Vec3 v = s;
    for (int k = 0; k < 3; ++k) v[k] -= 2 * pi * std::round((v[k] - near[k]) / (2 * pi));
    const double dist = std::fabs(v[0] - near[0]) + std::fabs(v[1] - near[1]) + std::fabs(v[2] - near[2]);
    if (dist < best_distance) {
      best_distance = dist;
      best = v;
    }
  }
  return best;
}


Mat34 invert_rigid(const Mat34& m) {
  Mat34 r{};
  for (size_t i = 0; i < 3; ++i) {
    for (size_t j = 0; j < 3; ++j) r[i * 4 + j] = m[j * 4 + i];
    r[i * 4 + 3] = -(m[0 * 4 + i] * m[3] + m[1 * 4 + i] * m[7] + m[2 * 4 + i] * m[11]);
  }
  return r;
}

Mat34 rigid_about(const Mat3& r, const Vec3& pivot, const Vec3& destination) {
  Mat34 m{};
  for (size_t k = 0; k < 3; ++k) {
    double t = destination[k];
    for (size_t i = 0; i < 3; ++i) {
      m[k * 4 + i] = r[k * 3 + i];
      t -= r[k * 3 + i] * pivot[i];
    }
    m[k * 4 + 3] = t;
  }
  return m;
}

Mat34 compose_rigid(const Mat34& a, const Mat34& b) {
  Mat34 out{};
  for (size_t r = 0; r < 3; ++r) {
    for (size_t c = 0; c < 4; ++c) {
      double v = 0;
      for (size_t k = 0; k < 3; ++k) v += a[r * 4 + k] * b[k * 4 + c];
      out[r * 4 + c] = v;
    }
    out[r * 4 + 3] += a[r * 4 + 3];
  }
  return out;
}

Vec3 apply_rigid(const Mat34& m, const Vec3& x) {
  Vec3 y{};
  for (size_t i = 0; i < 3; ++i) y[i] = m[i * 4] * x[0] + m[i * 4 + 1] * x[1] + m[i * 4 + 2] * x[2] + m[i * 4 + 3];
  return y;
}

std::array<double, 6> motion_at(const float* rows, int frames, double t) {
  std::array<double, 6> m{};
  size_t f0 = 0;
  double w = 0;
  if (frames >= 2) {
    // The kernel's float arithmetic, so that a frame's time picks the same rows.
    const float u = std::clamp((static_cast<float>(t) + 1.0f) * 0.5f * static_cast<float>(frames), 0.0f,
                               static_cast<float>(frames - 1));
    f0 = std::min(static_cast<size_t>(std::floor(u)), static_cast<size_t>(frames - 2));
    w = static_cast<double>(u) - static_cast<double>(f0);
  }
  for (size_t j = 0; j < 6; ++j)
    m[j] = (1 - w) * rows[f0 * 6 + j] + (frames >= 2 ? w * rows[(f0 + 1) * 6 + j] : 0.0);
  return m;
}

Vec3 motion_pivot(const float* rows, int frames) {
  Vec3 q{};
  for (size_t f = 0; f < static_cast<size_t>(frames); ++f)
    for (size_t k = 0; k < 3; ++k) q[k] += rows[f * 6 + 3 + k];
  for (double& v : q) v /= frames;
  return q;
}

Mat34 motion_matrix(const float* rows, int frames, double t) {
  const std::array<double, 6> m = motion_at(rows, frames, t);
  const Mat3 R = euler_xyz_to_matrix({m[0], m[1], m[2]});
  const Vec3 q = motion_pivot(rows, frames);
  Mat34 x{};
  for (size_t i = 0; i < 3; ++i) {
    double rt = 0;
    for (size_t k = 0; k < 3; ++k) {
      x[i * 4 + k] = R[i * 3 + k];
      rt += R[i * 3 + k] * m[3 + k];
    }
    x[i * 4 + 3] = q[i] - rt;
  }
  return x;
}

Vec3 motion_to_canonical(const float* rows, int frames, double t, const Vec3& x) {
  return apply_rigid(motion_matrix(rows, frames, t), x);
}

Vec3 motion_from_canonical(const float* rows, int frames, double t, const Vec3& y) {
  return apply_rigid(invert_rigid(motion_matrix(rows, frames, t)), y);
}

}  // namespace nova

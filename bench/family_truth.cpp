#include "family_truth.hpp"

#include <algorithm>
#include <cmath>

#include "nova/runtime/error.hpp"
#include "nova/sampling/camera.hpp"

namespace nova::bench {

Mat3 multiply(const Mat3& a, const Mat3& b) {
  Mat3 c{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int l = 0; l < 3; ++l) c[size_t(i * 3 + j)] += a[size_t(i * 3 + l)] * b[size_t(l * 3 + j)];
  return c;
}

Mat3 transpose(const Mat3& a) {
  Mat3 c{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) c[size_t(i * 3 + j)] = a[size_t(j * 3 + i)];
  return c;
}

Mat3 rotation_of(const std::array<double, 12>& p) { return {p[0], p[1], p[2], p[4], p[5], p[6], p[8], p[9], p[10]}; }

double turn_degrees(const Mat3& r) {
  return std::acos(std::clamp((r[0] + r[4] + r[8] - 1) / 2, -1.0, 1.0)) * 180.0 / 3.14159265358979323846;
}

std::vector<int> match_objects(const Scene& scene, const SynthWorld& world) {
  const int F = int(scene.frames.size()), K = int(scene.frames[0].masks.size()) - 1;
  std::vector<std::vector<long>> shared(size_t(world.objects()) + 1, std::vector<long>(size_t(K) + 1, 0));
  for (int i = 0; i < F; ++i) {
    const auto truth = world.render(world.camera(i), frame_time(i, F)).masks;
    for (int k = 1; k <= world.objects(); ++k)
      for (int m = 1; m <= K; ++m) {
        const Image8& a = truth[size_t(k)];
        const Image8& b = scene.frames[size_t(i)].masks[size_t(m)];
        for (size_t p = 0; p < a.data.size(); ++p) shared[size_t(k)][size_t(m)] += a.data[p] && b.data[p] >= 128;
      }
  }
  std::vector<int> out(size_t(world.objects()) + 1, 0);
  for (int k = 1; k <= world.objects(); ++k)
    for (int m = 1; m <= K; ++m)
      if (!out[size_t(k)] || shared[size_t(k)][size_t(m)] > shared[size_t(k)][size_t(out[size_t(k)])]) out[size_t(k)] = m;
  return out;
}

LoadedWorld loaded_world(const Scene& scene, const SynthWorld& world) {
  LoadedWorld w;
  const int F = int(scene.frames.size());
  w.turn = multiply(rotation_of(scene.frames[0].camera.c2w), transpose(rotation_of(world.camera(0).c2w)));
  // The scale: the widest camera baseline, loaded against generated.
  double best = 0;
  for (int i = 1; i < F; ++i) {
    const Camera &a = scene.frames[0].camera, &b = scene.frames[size_t(i)].camera;
    const Camera wa = world.camera(0), wb = world.camera(i);
    const double dw = std::hypot(wa.position(0) - wb.position(0), wa.position(1) - wb.position(1), wa.position(2) - wb.position(2));
    if (dw > best) {
      best = dw;
      w.scale = std::hypot(a.position(0) - b.position(0), a.position(1) - b.position(1), a.position(2) - b.position(2)) / dw;
    }
  }
  for (size_t i = 0; i < 3; ++i)
    for (size_t k = 0; k < 3; ++k) w.point[i * 4 + k] = w.scale * w.turn[i * 3 + k];
  const Camera c = world.camera(0);
  const Vec3 p = apply_rigid(w.point, {c.position(0), c.position(1), c.position(2)});
  for (size_t i = 0; i < 3; ++i) w.point[i * 4 + 3] = scene.frames[0].camera.position(int(i)) - p[i];
  return w;
}

std::vector<float> exact_motion_rows(const Scene& scene, const SynthWorld& world, const std::vector<float>& start) {
  const int F = int(scene.frames.size()), K = int(scene.frames[0].masks.size()) - 1;
  if (start.size() != size_t(K) * size_t(F) * 6)
    throw Error("exact_motion_rows: " + std::to_string(start.size()) + " start numbers for " + std::to_string(K) +
                    " objects x " + std::to_string(F) + " frames x 6", kExitInternal);
  const std::vector<int> scene_object = match_objects(scene, world);
  const LoadedWorld loaded = loaded_world(scene, world);
  std::vector<float> rows = start;
  for (int k = 1; k <= world.objects(); ++k) {
    const int m = scene_object[size_t(k)];
    if (m < 1) continue;
    int first = -1;  // the first frame whose mask shows the object
    for (int i = 0; i < F && first < 0; ++i) {
      const Image8& mask = scene.frames[size_t(i)].masks[size_t(m)];
      if (std::any_of(mask.data.begin(), mask.data.end(), [](uint8_t v) { return v >= 128; })) first = i;
    }
    if (first < 0) continue;
    float* r = rows.data() + size_t(m - 1) * size_t(F) * 6;
    // The start's pose (canonical -> world) at that frame: its row holds the Euler angles of
    // the pose's rotation transposed and the pose's translation (initial_motion).
    const Mat3 start_turn = transpose(euler_xyz_to_matrix({r[first * 6], r[first * 6 + 1], r[first * 6 + 2]}));
    const Vec3 origin{r[first * 6 + 3], r[first * 6 + 4], r[first * 6 + 5]};
    const Pose34 p0 = world.object_pose(k, frame_time(first, F));
    const Vec3 c0 = apply_rigid(loaded.point, {p0[3], p0[7], p0[11]});
    const Mat3 r0 = rotation_of(p0);
    const Vec3 offset{origin[0] - c0[0], origin[1] - c0[1], origin[2] - c0[2]};  // the origin from the true centre
    Vec3 angles{r[first * 6], r[first * 6 + 1], r[first * 6 + 2]};
    for (int i = 0; i < F; ++i) {
      const Pose34 pi = world.object_pose(k, frame_time(i, F));
      // The true turn from the first frame to frame i, in the loaded world.
      const Mat3 turn = multiply(loaded.turn, multiply(multiply(rotation_of(pi), transpose(r0)), transpose(loaded.turn)));
      const Mat3 pose_turn = multiply(turn, start_turn);
      const Vec3 ci = apply_rigid(loaded.point, {pi[3], pi[7], pi[11]});
      Vec3 t{};
      for (int a = 0; a < 3; ++a) {
        t[a] = ci[a];
        for (int b = 0; b < 3; ++b) t[a] += turn[size_t(a * 3 + b)] * offset[b];
      }
      angles = matrix_to_euler_xyz(transpose(pose_turn), angles);
      for (int d = 0; d < 3; ++d) {
        r[i * 6 + d] = float(angles[d]);
        r[i * 6 + 3 + d] = float(t[d]);
      }
    }
  }
  return rows;
}

}  // namespace nova::bench

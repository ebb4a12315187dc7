#pragma once
// The pose processing of the reference LLFF loader (NeRF's load_llff.py, reused by
// DynamicNeRF and NOVA), reimplemented:
// 1. poses_bounds.npy rows hold a row-major 3x5 matrix [down, right, back | centre | H W f]
//    and then near, far; the axes become OpenGL's [right, up, back] = [c1, -c0, c2].
// 2. Scale: translations and bounds are multiplied by 1 / (p5(near) * bd_factor), with p5
//    numpy's default (linear) 5th percentile of the near bounds. bd_factor is 0.75 for NeRF's
//    LLFF scenes and 0.9 in DynamicNeRF / NOVA.
// 3. Recentre: the average pose (mean centre, normalised summed back axis, up from the
//    summed up axes) is moved to the identity: every pose is left-multiplied by its inverse.
// The result is a similarity transform of the world, applied the same way to held-out and
// ground-truth cameras so that they share the training frame.
#include <array>
#include <vector>

namespace nova {

using Pose34 = std::array<double, 12>;  // row-major 3x4 camera-to-world (OpenGL axes)

// Row `r` of poses_bounds (17 values): the camera-to-world in OpenGL axes.
Pose34 llff_row_to_gl(const double* row17);
// The inverse: OpenGL c2w to the 3x5 LLFF block (15 values, hwf appended).
std::array<double, 15> gl_to_llff_block(const Pose34& c2w, double h, double w, double f);

double percentile_linear(std::vector<double> values, double q);  // numpy default

struct WorldTransform {
  double scale = 1;            // applied to positions first
  Pose34 recenter{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};  // then this rigid map (inv(avg))

  Pose34 apply(const Pose34& c2w) const;  // a raw camera to the processed frame
  std::array<double, 3> apply_point(const std::array<double, 3>& p) const;
  std::array<double, 3> apply_direction(const std::array<double, 3>& d) const;
};

// The transform the reference loader applies, from raw OpenGL poses and their near bounds.
// bd_factor <= 0 means no rescaling; recenter false skips step 3.
WorldTransform llff_world_transform(const std::vector<Pose34>& raw_c2w,
                                    const std::vector<double>& near_bounds, double bd_factor,
                                    bool recenter = true);

Pose34 pose_multiply(const Pose34& a, const Pose34& b);  // a * b as 4x4 with [0 0 0 1]
Pose34 pose_inverse(const Pose34& rigid);

}  // namespace nova

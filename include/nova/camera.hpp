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
#include <array>

namespace nova {

struct Camera {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::array<double, 12> c2w{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};

  double rotation(int r, int c) const { return c2w[r * 4 + c]; }
  double position(int r) const { return c2w[r * 4 + 3]; }
};

}  // namespace nova

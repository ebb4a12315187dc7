// Novel-view augmentation: camera rotation, its homography, bilinear warping, composite
// targets (see include/nova/train/augment.hpp).
#include "nova/train/augment.hpp"

#include <cmath>

#include "nova/runtime/error.hpp"

namespace nova {
namespace {

using M3 = std::array<double, 9>;

M3 mul(const M3& a, const M3& b) {
  M3 r{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      r[i * 3 + j] = a[i * 3] * b[j] + a[i * 3 + 1] * b[3 + j] + a[i * 3 + 2] * b[6 + j];
  return r;
}

M3 axis_matrix(const CameraRotation& r) {
  const double a = r.degrees * std::acos(-1.0) / 180.0, c = std::cos(a), s = std::sin(a);
  if (r.axis == RotationAxis::x) return {1, 0, 0, 0, c, -s, 0, s, c};
  return {c, 0, s, 0, 1, 0, -s, 0, c};
}

}  // namespace

CameraRotation random_rotation(std::mt19937& rng, double max_degrees) {
  CameraRotation r;
  r.axis = (rng() & 1u) ? RotationAxis::y : RotationAxis::x;
  const double u = double(rng() >> 8) * (1.0 / 16777216.0);  // [0, 1)
  r.degrees = (2.0 * u - 1.0) * max_degrees;
  return r;
}

Camera rotate_camera(const Camera& camera, const CameraRotation& rotation) {
  const M3 ra = axis_matrix(rotation);
  const M3 rc{camera.c2w[0], camera.c2w[1], camera.c2w[2], camera.c2w[4],  camera.c2w[5],
              camera.c2w[6], camera.c2w[8], camera.c2w[9], camera.c2w[10]};
  const M3 rn = mul(rc, ra);
  Camera out = camera;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) out.c2w[i * 4 + j] = rn[i * 3 + j];
  return out;
}

M3 rotation_homography(const Camera& c, const CameraRotation& rotation) {
  // camera.hpp: d = ((i - cx)/fx, -(j - cy)/fy, -1) = Kinv (i, j, 1); its inverse K maps a
  // camera-space direction back to homogeneous pixels (w = -d_z > 0 in front).
  const M3 k{c.fx, 0, -c.cx, 0, -c.fy, -c.cy, 0, 0, -1};
  const M3 kinv{1 / c.fx, 0, -c.cx / c.fx, 0, -1 / c.fy, c.cy / c.fy, 0, 0, -1};
  // A rotated-camera direction d' is R d' in the original camera's axes.
  return mul(k, mul(axis_matrix(rotation), kinv));
}

Image8 warp_image(const Image8& src, const M3& h, uint8_t fill, Image8* valid) {
  Image8 out(src.width, src.height, src.channels, fill);
  if (valid) *valid = Image8(src.width, src.height, 1, 0);
  const int ch = src.channels;
  for (int j = 0; j < src.height; ++j) {
    for (int i = 0; i < src.width; ++i) {
      const double w = h[6] * i + h[7] * j + h[8];
      if (w <= 0) continue;  // the ray points behind the original camera
      const double x = (h[0] * i + h[1] * j + h[2]) / w, y = (h[3] * i + h[4] * j + h[5]) / w;
      if (!(x >= 0 && y >= 0 && x <= src.width - 1 && y <= src.height - 1)) continue;
      const int x0 = std::min(int(x), src.width - 2 < 0 ? 0 : src.width - 2);
      const int y0 = std::min(int(y), src.height - 2 < 0 ? 0 : src.height - 2);
      const int x1 = std::min(x0 + 1, src.width - 1), y1 = std::min(y0 + 1, src.height - 1);
      const double fx = x - x0, fy = y - y0;
      for (int c = 0; c < ch; ++c) {
        const double v = (1 - fy) * ((1 - fx) * src.at(x0, y0, c) + fx * src.at(x1, y0, c)) +
                         fy * ((1 - fx) * src.at(x0, y1, c) + fx * src.at(x1, y1, c));
        out.at(i, j, c) = static_cast<uint8_t>(std::lround(v));
      }
      if (valid) valid->at(i, j) = 255;
    }
  }
  return out;
}

AugmentedFrame augment_frame(const Frame& frame,
                             const std::vector<std::optional<CameraRotation>>& rotations) {
  const int k_objects = int(frame.masks.size()) - 1;
  if (int(rotations.size()) != k_objects)
    throw Error("augment_frame: " + std::to_string(rotations.size()) + " rotations for " +
                std::to_string(k_objects) + " objects");
  AugmentedFrame a;
  a.rgb = frame.rgb;
  a.masks = frame.masks;
  a.cameras.assign(size_t(1 + k_objects), frame.camera);
  a.valid.assign(size_t(1 + k_objects), Image8(frame.rgb.width, frame.rgb.height, 1, 255));
  a.images.assign(size_t(1 + k_objects), frame.rgb);
  std::vector<Image8> warped(size_t(1 + k_objects));  // each turned object's own warped mask
  for (int k = 1; k <= k_objects; ++k) {
    if (!rotations[k - 1]) continue;
    const auto h = rotation_homography(frame.camera, *rotations[k - 1]);
    a.cameras[k] = rotate_camera(frame.camera, *rotations[k - 1]);
    a.images[k] = warp_image(frame.rgb, h);
    const Image8& img = a.images[k];
    a.masks[k] = warp_image(frame.masks[k], h, 0, &a.valid[k]);
    warped[size_t(k)] = a.masks[k];
    // Warped object over the composite so far, by its (fractional) warped mask; the
    // background loses every pixel the warped object covers (mask >= 0.5), as the
    // reference removes object pixels from the static NeRF's sampling mask. Objects are
    // layered in index order, so the other objects' masks lose those pixels too (a later
    // rotated object re-warps its own mask from the frame).
    for (size_t p = 0; p < a.masks[k].data.size(); ++p) {
      const int m = a.masks[k].data[p];
      if (!m) continue;
      for (int c = 0; c < 3; ++c) {
        uint8_t& dst = a.rgb.data[p * 3 + c];
        dst = static_cast<uint8_t>((img.data[p * 3 + c] * m + dst * (255 - m) + 127) / 255);
      }
      if (m >= 128)
        for (int j = 0; j <= k_objects; ++j)
          if (j != k) a.masks[j].data[p] = 0;
    }
  }
  // Where a turned object stood in the frame and no warped object stands now, the frame
  // shows the object while every mask says empty; the background behind it was never seen,
  // so the pixel has no target. Where a warped object meets another object (warped or where
  // the frame shows it), which of the two is in front is not known: each object renders from
  // a camera of its own, and pasting the warped one on top would tell the other one's NeRF
  // that it is absent where it stands. Such pixels are left out (valid[0] = 0).
  for (size_t p = 0; p < a.valid[0].data.size(); ++p) {
    bool vacated = false, covered = false;
    int present = 0;
    for (int k = 1; k <= k_objects; ++k) {
      const bool turned = rotations[k - 1].has_value();
      const bool here = turned ? warped[size_t(k)].data[p] >= 128 : frame.masks[k].data[p] > 0;
      present += here;
      if (!turned) continue;
      vacated |= frame.masks[k].data[p] > 0;
      covered |= here;
    }
    if ((vacated && !covered) || (covered && present > 1)) a.valid[0].data[p] = 0;
  }
  return a;
}

}  // namespace nova

// Novel-view augmentation against ground truth: for a synthetic scene, the image warped by
// the homography K R K^-1 must match a fresh render from the rotated camera inside the warp's
// valid region.
#include <boost/test/unit_test.hpp>
#include <algorithm>
#include <cmath>

#include "nova/train/augment.hpp"
#include "nova/data/synth.hpp"
#include "scene_test_util.hpp"

using namespace nova;
using namespace nova::test;

namespace {

const CameraRotation kRotations[] = {{RotationAxis::x, 15.0},
                                     {RotationAxis::y, -20.0},
                                     {RotationAxis::y, 20.0},
                                     {RotationAxis::x, -9.5}};

// World-space ray direction of pixel (i, j), normalised (camera.hpp's convention).
std::array<double, 3> ray(const Camera& c, double i, double j) {
  const double d[3] = {(i - c.cx) / c.fx, -(j - c.cy) / c.fy, -1.0};
  std::array<double, 3> w{};
  for (int r = 0; r < 3; ++r) w[r] = c.rotation(r, 0) * d[0] + c.rotation(r, 1) * d[1] + c.rotation(r, 2) * d[2];
  const double n = std::sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
  for (auto& v : w) v /= n;
  return w;
}

// The surface owner (0 background, k object) of a render pixel.
int owner(const SynthRender& r, int x, int y) {
  for (int k = 0; k < int(r.masks.size()); ++k)
    if (r.masks[k].at(x, y)) return k;
  return -1;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(augment)

BOOST_AUTO_TEST_CASE(homography_maps_rays_exactly) {
  const SynthWorld w("tiny", 1);
  const Camera cam = w.camera(3);
  for (const auto& rot : kRotations) {
    const Camera rc = rotate_camera(cam, rot);
    for (int k = 0; k < 3; ++k) BOOST_TEST(rc.position(k) == cam.position(k));
    const auto h = rotation_homography(cam, rot);
    for (const auto& [i, j] : {std::pair{0.0, 0.0}, {63.0, 47.0}, {10.5, 30.25}, {32.0, 24.0}}) {
      const double z = h[6] * i + h[7] * j + h[8];
      BOOST_TEST(z > 0);
      const double x = (h[0] * i + h[1] * j + h[2]) / z, y = (h[3] * i + h[4] * j + h[5]) / z;
      const auto a = ray(rc, i, j), b = ray(cam, x, y);
      for (int r = 0; r < 3; ++r) BOOST_TEST(std::abs(a[r] - b[r]) < 1e-12);
    }
  }
}

BOOST_AUTO_TEST_CASE(random_rotation_range) {
  std::mt19937 rng(5);
  int axes[2] = {0, 0};
  for (int n = 0; n < 1000; ++n) {
    const auto r = random_rotation(rng, 20.0);
    BOOST_TEST(std::abs(r.degrees) <= 20.0);
    ++axes[r.axis == RotationAxis::x ? 0 : 1];
  }
  BOOST_TEST(axes[0] > 400);
  BOOST_TEST(axes[1] > 400);
}

// Tolerance. The renders are point-sampled (one ray per pixel, no anti-aliasing), so the warp
// differs from a fresh render only by bilinear resampling of the original image:
// - where the four source pixels lie on one smooth surface (same owner, depths within 3%:
//   "interior"), the error is the interpolation error of a smooth texture, |f''| h^2 / 8 per
//   axis, plus 8-bit rounding: the textures here change by a few levels per pixel, so we
//   require a mean under 2 levels and a 99th percentile under 10 (measured 3-7; box edges,
//   where depth is continuous but the face colour is not, make the rare larger errors);
// - on silhouettes and texture/shading edges the interpolated value mixes two surfaces (up
//   to the full contrast), on a band about one pixel wide, so those pixels only enter the
//   overall PSNR, required to exceed 30 dB on the valid region (measured: 35-37 dB).
BOOST_AUTO_TEST_CASE(warp_matches_fresh_render) {
  const SynthWorld w("default", 5);
  const int frame = 6;
  const double t = frame_time(frame, w.preset().frames);
  const Camera cam = w.camera(frame);
  const SynthRender src = w.render(cam, t);
  for (const auto& rot : kRotations) {
    const Camera rc = rotate_camera(cam, rot);
    const SynthRender truth = w.render(rc, t);
    const auto h = rotation_homography(cam, rot);
    Image8 valid;
    const Image8 warped = warp_image(src.rgb, h, 0, &valid);
    double sq = 0, n = 0, interior_abs = 0, interior_n = 0;
    std::vector<double> interior_err;
    for (int y = 0; y < cam.height; ++y)
      for (int x = 0; x < cam.width; ++x) {
        if (!valid.at(x, y)) continue;
        const double z = h[6] * x + h[7] * y + h[8];
        const double sx = (h[0] * x + h[1] * y + h[2]) / z, sy = (h[3] * x + h[4] * y + h[5]) / z;
        const int x0 = std::min(int(sx), cam.width - 2), y0 = std::min(int(sy), cam.height - 2);
        const int o = owner(truth, x, y);
        bool interior = o >= 0;
        const double d0 = src.depth.data[size_t(y0) * cam.width + x0];
        for (const auto& [dx, dy] : {std::pair{0, 0}, {1, 0}, {0, 1}, {1, 1}}) {
          const double d = src.depth.data[size_t(y0 + dy) * cam.width + x0 + dx];
          interior = interior && owner(src, x0 + dx, y0 + dy) == o && std::abs(d - d0) < 0.03 * d0;
        }
        for (int c = 0; c < 3; ++c) {
          const double e = double(warped.at(x, y, c)) - truth.rgb.at(x, y, c);
          sq += e * e;
          n += 1;
          if (interior) {
            interior_abs += std::abs(e);
            interior_n += 1;
            interior_err.push_back(std::abs(e));
          }
        }
      }
    std::sort(interior_err.begin(), interior_err.end());
    const double p99 = interior_err[size_t(0.99 * double(interior_err.size() - 1))];
    const double psnr = 10 * std::log10(255.0 * 255.0 / (sq / n));
    const double valid_frac = n / (3.0 * cam.width * cam.height);
    BOOST_TEST_MESSAGE("rotation " << (rot.axis == RotationAxis::x ? "x " : "y ") << rot.degrees
                       << ": valid " << valid_frac << ", PSNR " << psnr << " dB, interior mean "
                       << interior_abs / interior_n << ", p99 " << p99 << " over "
                       << interior_err.size() / 3 << " pixels");
    BOOST_TEST(valid_frac > 0.5);
    BOOST_TEST(psnr > 30.0);
    BOOST_TEST(interior_abs / interior_n < 2.0);
    BOOST_TEST(p99 <= 10.0);
    BOOST_TEST(interior_err.size() > 0.8 * n);

    // Object masks: the warped mask (>= 0.5) disagrees with the rendered one only on the
    // silhouette band, a small fraction of the object's area.
    for (int k = 1; k <= w.objects(); ++k) {
      const Image8 wm = warp_image(src.masks[k], h);
      double area = 0, wrong = 0;
      for (int y = 0; y < cam.height; ++y)
        for (int x = 0; x < cam.width; ++x) {
          if (!valid.at(x, y)) continue;
          const bool a = wm.at(x, y) >= 128, b = truth.masks[k].at(x, y) != 0;
          area += b;
          wrong += a != b;
        }
      if (area > 100) BOOST_TEST(wrong / area < 0.15, "object " << k << ": " << wrong << " / " << area);
    }
  }
}

BOOST_AUTO_TEST_CASE(composite_target) {
  const SynthWorld w("default", 5);
  const int frame = 10;
  const double t = frame_time(frame, w.preset().frames);
  Frame f;
  f.camera = w.camera(frame);
  const SynthRender src = w.render(f.camera, t);
  f.rgb = src.rgb;
  f.masks = src.masks;
  const CameraRotation rot{RotationAxis::y, 12.0};
  const AugmentedFrame a = augment_frame(f, {rot, std::nullopt});
  BOOST_TEST(a.masks.size() == 3u);
  // Object 2 is not rotated: its mask changes only where warped object 1 now covers it.
  for (size_t p = 0; p < f.masks[2].data.size(); ++p)
    if (a.masks[1].data[p] < 128) BOOST_TEST(a.masks[2].data[p] == f.masks[2].data[p]);
  BOOST_TEST(a.cameras[2].c2w == f.camera.c2w);
  BOOST_TEST(a.cameras[1].c2w != f.camera.c2w);
  // ... object 1 is, and where its warped mask is solid the composite shows the rotated
  // camera's view of object 1 and the background mask is cleared.
  const SynthRender obj = w.render_instances(a.cameras[1], false, {{1, w.object_pose(1, t)}});
  double err = 0, n = 0;
  size_t cleared = 0, covered = 0;
  for (int y = 1; y < f.camera.height - 1; ++y)
    for (int x = 1; x < f.camera.width - 1; ++x) {
      if (a.masks[1].at(x, y) != 255) continue;
      ++covered;
      cleared += a.masks[0].at(x, y) == 0;
      if (!obj.masks[1].at(x, y)) continue;
      for (int c = 0; c < 3; ++c) err += std::abs(double(a.rgb.at(x, y, c)) - obj.rgb.at(x, y, c)), n += 1;
    }
  BOOST_TEST(covered > 100u);
  BOOST_TEST(cleared == covered);
  BOOST_TEST(err / n < 3.0);  // bilinear error, as above (silhouette band included)
  // Far from object 1 (both original and warped) the composite is the original frame.
  BOOST_TEST(a.rgb.at(2, 2, 0) == f.rgb.at(2, 2, 0));
  // Object 1's old place, where no warped object stands now, has no target: the frame
  // shows object 1 there while every mask is empty; nor has warped object 1 where it meets
  // object 2 (warped_object_over_another_has_no_target). Everywhere else the target is kept.
  size_t vacated = 0;
  for (size_t p = 0; p < f.masks[1].data.size(); ++p) {
    const bool hole = f.masks[1].data[p] > 0 && a.masks[1].data[p] < 128;
    const bool overlap = a.masks[1].data[p] >= 128 && f.masks[2].data[p] > 0;
    vacated += hole;
    BOOST_TEST(a.valid[0].data[p] == (hole || overlap ? 0 : 255), "pixel " << p);
  }
  BOOST_TEST(vacated > 100u);
  // Each NeRF's own view (the reference conventions' per-NeRF targets): the frame for the
  // static NeRF and the unrotated object 2, the whole frame warped by its homography for 1.
  BOOST_REQUIRE(a.images.size() == 3u);
  BOOST_TEST(a.images[0].data == f.rgb.data);
  BOOST_TEST(a.images[2].data == f.rgb.data);
  BOOST_TEST(a.images[1].data == warp_image(f.rgb, rotation_homography(f.camera, rot)).data);
  BOOST_TEST(a.images[1].data != f.rgb.data);
}

// A warped object that lands on another object's pixels: each NeRF renders from a camera of
// its own, so which of the two is in front there is unknown, and those pixels get no target;
// the warped object's other pixels keep theirs.
BOOST_AUTO_TEST_CASE(warped_object_over_another_has_no_target) {
  Frame f;
  f.camera.width = 96;
  f.camera.height = 48;
  f.camera.fx = f.camera.fy = 60.0;
  f.camera.cx = 48.0;
  f.camera.cy = 24.0;
  f.rgb = Image8(96, 48, 3, 90);
  f.masks.assign(3, Image8(96, 48, 1, 0));
  for (int y = 16; y < 32; ++y)
    for (int x = 40; x < 56; ++x) f.masks[1].at(x, y) = 255;  // object 1: a square in the middle
  const CameraRotation rot{RotationAxis::y, 20.0};
  const Image8 moved = warp_image(f.masks[1], rotation_homography(f.camera, rot));
  int left = 96, right = -1;
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 96; ++x)
      if (moved.at(x, y) >= 128) left = std::min(left, x), right = std::max(right, x);
  BOOST_REQUIRE(right - left > 10);
  BOOST_REQUIRE((right < 40 || left >= 56));  // the turned square has left its old place
  // Object 2 on the turned square's outer half (away from its old place), and 3 px beyond.
  const int middle = (left + right) / 2;
  const int from = left >= 56 ? middle : std::max(0, left - 3), to = left >= 56 ? std::min(95, right + 3) : middle;
  for (int y = 0; y < 48; ++y)
    for (int x = from; x <= to; ++x) f.masks[2].at(x, y) = 255;
  for (size_t p = 0; p < f.masks[0].data.size(); ++p)
    f.masks[0].data[p] = (f.masks[1].data[p] || f.masks[2].data[p]) ? 0 : 255;

  const AugmentedFrame a = augment_frame(f, {rot, std::nullopt});
  size_t overlap = 0, alone = 0, vacated = 0;
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 96; ++x) {
      const bool covers = moved.at(x, y) >= 128, other = f.masks[2].at(x, y) > 0, old = f.masks[1].at(x, y) > 0;
      const uint8_t v = a.valid[0].at(x, y);
      if (covers && other) {
        ++overlap;
        BOOST_TEST(v == 0, "overlap at " << x << ", " << y);
      } else if (covers) {
        ++alone;
        BOOST_TEST(v == 255, "warped object alone at " << x << ", " << y);
      } else if (old) {
        ++vacated;
        BOOST_TEST(v == 0, "vacated at " << x << ", " << y);
      } else {
        BOOST_TEST(v == 255, "untouched at " << x << ", " << y);
      }
    }
  BOOST_TEST(overlap > 20u);
  BOOST_TEST(alone > 20u);
  BOOST_TEST(vacated > 100u);
}

BOOST_AUTO_TEST_SUITE_END()

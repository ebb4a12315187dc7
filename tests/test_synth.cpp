// The synthetic generator: determinism (byte-identical files for a seed), the camera
// convention of camera.hpp, staged output (nothing written on error), composition targets.
#include <boost/test/unit_test.hpp>
#include <chrono>
#include <cmath>

#include "nova/data/scene_io.hpp"
#include "nova/data/synth.hpp"
#include "scene_test_util.hpp"

using namespace nova;
using namespace nova::test;

namespace {

std::map<std::string, std::string> all_files(const fs::path& root) {
  std::map<std::string, std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(root))
    if (e.is_regular_file()) out[fs::relative(e.path(), root).string()] = read_all(e.path());
  return out;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(synth)

BOOST_AUTO_TEST_CASE(same_seed_same_bytes) {
  TempDir tmp("synth");
  write_synthetic_scene((tmp / "a").string(), "tiny", 11);
  write_synthetic_scene((tmp / "b").string(), "tiny", 11);
  write_synthetic_scene((tmp / "c").string(), "tiny", 12);
  const auto a = all_files(tmp / "a"), b = all_files(tmp / "b"), c = all_files(tmp / "c");
  BOOST_TEST(a.size() == b.size());
  BOOST_TEST(a.size() > 80u);
  for (const auto& [name, bytes] : a) BOOST_TEST((b.count(name) && b.at(name) == bytes), name);
  BOOST_TEST(a.at("images/000.png") != c.at("images/000.png"));  // the seed matters
}

BOOST_AUTO_TEST_CASE(camera_convention) {
  // A ray through pixel (i, j) of camera.hpp's convention hits the point that projects back
  // to (i, j): check with the rendered depth of the background at a few pixels.
  const SynthWorld w("tiny", 3);
  const Camera cam = w.camera(4);
  const SynthRender r = w.render(cam, 0.0);
  // Depth is z-depth: the point is o + depth * R ((i - cx)/fx, -(j - cy)/fy, -1); its camera
  // z must be -depth, and the principal ray (cx, cy) is the camera's -z axis.
  const int i = int(cam.cx), j = int(cam.cy);
  const double depth = r.depth.data[size_t(j) * cam.width + i];
  BOOST_TEST(depth > 2.0);
  // z-depth, not distance along the ray: pixel (i0, j) a quarter width right of the centre
  // sees a point at distance depth0 * sqrt(1 + dx^2) (dx = (i0 - cx) / fx); a camera at the
  // same place turned about its y axis so that its principal ray is that ray sees the same
  // point at its centre pixel, where z-depth and distance agree. The renders are analytic:
  // 1e-4 relative covers float rounding, while the factor sqrt(1 + dx^2) is > 1.02 here.
  const int i0 = i + cam.width / 4;
  const double dx = (i0 - cam.cx) / cam.fx, depth0 = r.depth.data[size_t(j) * cam.width + i0];
  const double phi = -std::atan(dx), c = std::cos(phi), s = std::sin(phi);
  const double ry[3][3] = {{c, 0, s}, {0, 1, 0}, {-s, 0, c}};
  Camera turned = cam;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      double v = 0;
      for (int k = 0; k < 3; ++k) v += cam.rotation(a, k) * ry[k][b];
      turned.c2w[a * 4 + b] = v;
    }
  const double along = w.render(turned, 0.0).depth.data[size_t(j) * cam.width + i];
  BOOST_TEST(std::sqrt(1 + dx * dx) > 1.02);
  BOOST_TEST(std::fabs(along - depth0 * std::sqrt(1 + dx * dx)) <= 1e-4 * along,
             "turned camera's centre depth " << along << " against " << depth0 * std::sqrt(1 + dx * dx));
  // The image top row sees higher world y than the bottom row (y up, rows from the top).
  BOOST_TEST(r.masks[0].at(cam.width / 2, cam.height - 1) == 255);  // floor at the bottom
  // Moving the camera right moves the scene left in the image: check mask centroids.
  auto centroid_x = [](const Image8& m) {
    double s = 0, n = 0;
    for (int y = 0; y < m.height; ++y)
      for (int x = 0; x < m.width; ++x)
        if (m.at(x, y)) s += x, n += 1;
    return s / std::max(n, 1.0);
  };
  Camera right = cam;
  for (int k = 0; k < 3; ++k) right.c2w[k * 4 + 3] += 0.2 * cam.c2w[k * 4 + 0];
  const SynthRender r2 = w.render(right, 0.0);
  BOOST_TEST(centroid_x(r2.masks[1]) < centroid_x(r.masks[1]));
}

BOOST_AUTO_TEST_CASE(nothing_written_on_error) {
  TempDir tmp("synth");
  expect_error([&] { write_synthetic_scene((tmp / "x").string(), "huge", 1); }, {"preset 'huge'"});
  expect_error([&] { write_synthetic_scene((tmp / "no" / "such" / "x").string(), "tiny", 1); },
               {"does not exist"});
  fs::create_directories(tmp / "exists");
  expect_error([&] { write_synthetic_scene((tmp / "exists").string(), "tiny", 1); },
               {"already exists"});
  size_t entries = 0;
  for (const auto& e : fs::directory_iterator(tmp.path())) entries += e.path().filename() != "exists";
  BOOST_TEST(entries == 0u);  // no output, no temporary folder left behind
  BOOST_TEST(fs::is_empty(tmp / "exists"));
}

BOOST_AUTO_TEST_CASE(compose_targets_follow_the_spec) {
  // "objects_only" places both objects as they are at the last frame's time, seen by the last
  // frame's camera, without background: it must equal that frame where the masks say object.
  const Scene s = load_scene(cached_tiny_scene().string());
  const ComposeTarget* t = nullptr;
  for (const auto& x : s.compose.targets)
    if (x.name == "objects_only") t = &x;
  BOOST_REQUIRE(t);
  const Image8* img = nullptr;
  for (const auto& x : s.compose_gt)
    if (x.name == "objects_only") img = &x.rgb;
  BOOST_REQUIRE(img);
  const Frame& f = s.frames[t->camera];
  size_t obj = 0, mismatched = 0;
  for (int y = 0; y < f.rgb.height; ++y)
    for (int x = 0; x < f.rgb.width; ++x) {
      const bool is_obj = f.masks[1].at(x, y) || f.masks[2].at(x, y);
      obj += is_obj;
      for (int c = 0; c < 3; ++c) {
        // Object pixels equal the frame (up to 1 level: the instance map's round trip through
        // the processed frame perturbs hit points by ~1e-15); elsewhere black.
        const int want = is_obj ? f.rgb.at(x, y, c) : 0;
        mismatched += std::abs(int(img->at(x, y, c)) - want) > 1;
      }
    }
  BOOST_TEST(obj > 50u);
  BOOST_TEST(mismatched <= 3u);  // a silhouette pixel may flip under that perturbation
}

BOOST_AUTO_TEST_SUITE_END()

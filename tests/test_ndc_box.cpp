// The hash grid's box in NDC holds every training ray (RayGeometry::extent): NDC is the first
// camera's frustum, so a camera that moved sideways sees past |x| = 1, and a box clamped at 1
// gives every sample beyond it the encoding of the box's face (streaks in the renders).
// Tolerances: the extent is float64 arithmetic rounded to float once, so 1e-6 relative.
#include <boost/test/unit_test.hpp>
#include <algorithm>
#include <cmath>
#include <string>

#include "nova/model/fields.hpp"
#include "nova/model/field_graphs.hpp"
#include "nova/train/train_config.hpp"

using namespace nova;

namespace {

// A forward-facing NDC scene: each camera 80x60, focal 100, principal point at the centre,
// looking along -z from (tx, 0, 0), turned by `yaw` radians about y.
Scene ndc_scene(const std::vector<std::pair<double, double>>& tx_yaw) {
  Scene s;
  s.name = "ndc";
  s.ndc = true;
  s.near = 1.0;
  s.far = 5.0;
  for (const auto& [tx, yaw] : tx_yaw) {
    Frame f;
    Camera& c = f.camera;
    c.width = 80, c.height = 60, c.fx = c.fy = 100, c.cx = 40, c.cy = 30;
    const double co = std::cos(yaw), si = std::sin(yaw);
    c.c2w = {co, 0, si, tx, 0, 1, 0, 0, -si, 0, co, 0};
    s.frames.push_back(f);
  }
  return s;
}

// The largest |x|, |y| in NDC over a dense grid of pixels and of t in [0, 1) by brute force
// (the NDC map of kernels/sampling.cl, in float64).
double brute_force_extent(const Scene& s) {
  double e = 0;
  for (const Frame& f : s.frames) {
    const Camera& c = f.camera;
    for (int i = 0; i < c.width; i += 3)
      for (int j = 0; j < c.height; j += 3) {
        const double u = (i - c.cx) / c.fx, v = -(j - c.cy) / c.fy;
        double d[3], o[3];
        for (int k = 0; k < 3; ++k) {
          d[k] = c.rotation(k, 0) * u + c.rotation(k, 1) * v - c.rotation(k, 2);
          o[k] = c.position(k);
        }
        const double t0 = -(1.0 + o[2]) / d[2];
        for (int k = 0; k < 3; ++k) o[k] += t0 * d[k];
        const double ax = -c.fx / c.cx, ay = -c.fy / c.cy;
        const double no[2] = {ax * o[0] / o[2], ay * o[1] / o[2]};
        const double nd[2] = {ax * (d[0] / d[2] - o[0] / o[2]), ay * (d[1] / d[2] - o[1] / o[2])};
        for (double t = 0; t < 1.0; t += 0.01)
          for (int k = 0; k < 2; ++k) e = std::max(e, std::fabs(no[k] + t * nd[k]));
      }
  }
  return e;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(ndc_box)

BOOST_AUTO_TEST_CASE(one_unmoved_camera_is_the_unit_box) {
  BOOST_TEST(ray_geometry(ndc_scene({{0.0, 0.0}})).extent == 1.0f, boost::test_tools::tolerance(1e-6f));
}

BOOST_AUTO_TEST_CASE(a_camera_moved_sideways_widens_the_box) {
  // Moved left by 0.1: its left image edge meets the near plane at x = -0.1 - cx / fx, which
  // NDC maps to fx / cx (0.1 + cx / fx) = 1 + 0.1 fx / cx = 1.25.
  const float e = ray_geometry(ndc_scene({{0.0, 0.0}, {-0.1, 0.0}})).extent;
  BOOST_TEST(e == 1.25f, boost::test_tools::tolerance(1e-6f));
}

BOOST_AUTO_TEST_CASE(the_corners_bound_every_ray) {
  // Turned and moved cameras: the extent from the image corners' two ends is the largest
  // coordinate of any sample of any ray (rays are straight lines in NDC).
  const Scene s = ndc_scene({{0.0, 0.0}, {0.15, 0.05}, {-0.2, -0.08}, {0.05, 0.1}});
  const double brute = brute_force_extent(s);
  const float e = ray_geometry(s).extent;
  BOOST_TEST(brute > 1.3);  // the case does leave the unit box
  BOOST_TEST(e >= brute * (1 - 1e-6));
  // The brute force steps over pixels by 3 and t by 0.01, so it may fall a little short.
  BOOST_TEST(e <= brute * 1.05);
}

BOOST_AUTO_TEST_CASE(scene_field_takes_the_box_from_the_rays_unless_told_not_to) {
  const RayGeometry g = ray_geometry(ndc_scene({{0.0, 0.0}, {-0.1, 0.0}}));
  FieldConfig f = preset_config("quick").field;
  BOOST_TEST(f.hash.bound == 0.0f);
  BOOST_TEST(!f.ndc_box_from_rays);
  BOOST_TEST(scene_field(f, g).hash.bound == 1.0f);
  f.ndc_box_from_rays = true;
  // Per axis: x as wide as the rays, y and z the unit box (the camera moved along x only).
  const HashGridConfig h = scene_field(f, g).hash;
  BOOST_TEST(h.half_size(0) == 1.25f, boost::test_tools::tolerance(1e-6f));
  BOOST_TEST(h.half_size(1) == 1.0f);
  BOOST_TEST(h.half_size(2) == 1.0f);
  BOOST_TEST(h.max_half_size() == g.extent);
  f.ndc_box_from_rays = false;
  BOOST_TEST(scene_field(f, g).hash.bound == 1.0f);
  f.hash.bound = 0.7f;  // set by hand: kept
  BOOST_TEST(scene_field(f, g).hash.bound == 0.7f);
}

BOOST_AUTO_TEST_CASE(a_run_file_without_the_option_keeps_the_unit_box) {
  TrainConfig c = preset_config("quick");
  c.field.ndc_box_from_rays = true;
  std::string text = format_config(c);
  const std::string key = "\nhash-ndc-box-from-rays = ";
  const size_t at = text.find(key);
  BOOST_REQUIRE(at != std::string::npos);
  BOOST_TEST(parse_config_text(text, "config.ini", nullptr, ConfigFile::RunFile).field.ndc_box_from_rays);
  text.erase(at + 1, text.find('\n', at + 1) - at);
  BOOST_TEST(!parse_config_text(text, "config.ini", nullptr, ConfigFile::RunFile).field.ndc_box_from_rays);
  // A partial configuration without it takes the preset's value.
  BOOST_TEST(parse_config_text(text, "mine.ini").field.ndc_box_from_rays == preset_config("quick").field.ndc_box_from_rays);
}

BOOST_AUTO_TEST_SUITE_END()

// A rigid object's canonical field in a box of its own (object-box): the box holds the
// object's cube wherever the scene puts it (NDC or metric), the field reads the box's
// coordinates (a zero box is the identity, bit for bit), and the option needs the rigid model.
#include <boost/test/unit_test.hpp>
#include <algorithm>
#include <cmath>
#include <functional>
#include <string>

#include "field_test_util.hpp"
#include "harness.hpp"
#include "nova/model/fields.hpp"
#include "nova/runtime/error.hpp"
#include "nova/train/motion_init.hpp"
#include "nova/train/train_config.hpp"

using namespace nova;
using namespace nova::test;

namespace {

// The point x in the coordinates of box row b (box_coordinates' map, in double).
Vec3 in_box(const std::array<float, 6>& b, const Vec3& x) {
  Vec3 y{};
  for (size_t j = 0; j < 3; ++j) y[j] = (x[j] - b[j]) * std::exp(double(b[3 + j]));
  return y;
}

Vec3 to_ndc(const RayGeometry& g, const Vec3& x) {
  return {g.ax * x[0] / x[2], g.ay * x[1] / x[2], 1.0 + 2.0 / x[2]};
}

}  // namespace

BOOST_AUTO_TEST_SUITE(object_box)

BOOST_AUTO_TEST_CASE(holds_the_cube_in_ndc_and_metric_scenes) {
  // Every point of the cube maps inside [-1, 1]^3 and its corners reach the box's faces, on
  // both sides where the map is linear (metric) and on one side at least in NDC, where the
  // cube's near half stretches more than its far half (a cube of half-size 0.3 at depth 3:
  // (3 / 2.7)^2 = 1.23 times along z); a box larger than the scene's is cut to the scene's.
  RayGeometry ndc;
  ndc.ndc = true;
  ndc.ax = -1.6f;
  ndc.ay = -2.1f;
  RayGeometry metric;
  for (const RayGeometry& g : {ndc, metric}) {
    const Vec3 centre{0.4, -0.2, -3.0};
    const double half = 0.3;
    const std::array<float, 6> b = object_box_row(centre, half, g);
    const Vec3 c = in_box(b, g.ndc ? to_ndc(g, centre) : centre);
    for (double v : c) BOOST_TEST(std::fabs(v) < 0.2, "the centre at " << v << " in the box");
    std::array<double, 3> reach{};
    for (int i = 0; i < 27; ++i) {
      const Vec3 x{centre[0] + half * (i % 3 - 1), centre[1] + half * (i / 3 % 3 - 1), centre[2] + half * (i / 9 - 1)};
      const Vec3 y = in_box(b, g.ndc ? to_ndc(g, x) : x);
      for (size_t j = 0; j < 3; ++j) {
        BOOST_TEST(std::fabs(y[j]) <= 1.0 + 1e-5, "axis " << j << " of point " << i << " at " << y[j]);
        reach[j] = std::max(reach[j], std::fabs(y[j]));
      }
    }
    for (size_t j = 0; j < 3; ++j) BOOST_TEST(reach[j] > 1.0 - 1e-5, "axis " << j << " reaches " << reach[j]);
    const std::array<float, 6> large = object_box_row(centre, 30.0, g);
    for (size_t j = 0; j < 3; ++j)
      BOOST_TEST(std::exp(-double(large[3 + j])) == double(g.ndc ? g.box[j] : g.extent), boost::test_tools::tolerance(1e-6));
  }
}

BOOST_AUTO_TEST_CASE(a_zero_box_is_the_scene_cube) {
  // Zeros are the identity: the field with a box reads what it reads without one in the unit
  // cube, bit for bit; a box set elsewhere changes what it reads.
  FieldConfig plain = small_hash_field(32, ObjectMotion::Rigid);
  FieldConfig boxed = plain;
  boxed.object_box = true;
  const std::vector<float> times(2 * 30, 0.1f);
  const auto seed = [](const std::string& name) -> std::optional<unsigned> {
    if (name == kObjectBoxName) return std::nullopt;
    return static_cast<unsigned>(std::hash<std::string>{}(name) & 0xffff);
  };
  std::vector<std::string> names;
  const FieldRun a = run_object_fields(plain, times, seed);
  const FieldRun b = run_object_fields(boxed, times, seed);
  BOOST_TEST(a.raw == b.raw, boost::test_tools::per_element());
  BOOST_TEST(std::count(b.names.begin(), b.names.end(), kObjectBoxName) == 1);
  const FieldRun moved = run_object_fields(boxed, times, [&](const std::string& name) {
    return name == kObjectBoxName ? std::optional<unsigned>(7) : seed(name);
  });
  BOOST_TEST(moved.raw != a.raw);
}

BOOST_AUTO_TEST_CASE(option_reads_and_needs_the_rigid_model) {
  TrainConfig c = preset_config("quick");
  BOOST_TEST(c.field.object_box);  // quick's rigid objects have boxes of their own
  validate(c);
  const HashGridConfig h = object_hash_config(c.field);
  BOOST_TEST(h.bound == 1.0f);
  // The (x, y, z, t) field on quick: object-motion none takes the box with the rigid model.
  set_config_value(c, "object-motion", "none");
  BOOST_TEST(!c.field.object_box);
  validate(c);
  // Asked for together with it: an error that names both.
  set_config_value(c, "object-box", "true");
  try {
    validate(c);
    BOOST_FAIL("object-box without the rigid model was accepted");
  } catch (const Error& e) {
    const std::string what = e.what();
    BOOST_TEST(what.find("object-box") != std::string::npos, what);
    BOOST_TEST(what.find("object-motion") != std::string::npos, what);
  }
}

// The command line and a run's config.ini apply options in the table's order: object-box and
// object-samples after object-motion, so `--object-motion none --object-box true` is the error
// above, not a box quietly dropped.
BOOST_AUTO_TEST_CASE(object_box_is_applied_after_object_motion) {
  const auto& options = config_options();
  const auto at = [&](const std::string& key) {
    return std::find_if(options.begin(), options.end(), [&](const ConfigOption& o) { return o.key == key; });
  };
  BOOST_TEST_REQUIRE((at("object-box") != options.end()));
  BOOST_TEST((at("object-motion") < at("object-box")));
  // Samples crowd about the rigid objects (object_samples.hpp): after object-motion, which
  // turns them off.
  BOOST_TEST_REQUIRE((at("object-samples") != options.end()));
  BOOST_TEST((at("object-motion") < at("object-samples")));
}

BOOST_AUTO_TEST_CASE(object_samples_need_the_rigid_model_and_leave_samples_spread) {
  const auto refused = [](TrainConfig c, const std::string& names) {
    try {
      validate(c);
      BOOST_FAIL("accepted: " + names);
    } catch (const Error& e) {
      const std::string what = e.what();
      BOOST_TEST(what.find("object-samples") != std::string::npos, what);
      BOOST_TEST(what.find(names) != std::string::npos, what);
    }
  };
  TrainConfig c = preset_config("quick");
  set_config_value(c, "object-samples", "8");
  validate(c);
  set_config_value(c, "object-box", "false");  // the scene's box: still the rigid model
  validate(c);
  // As many as the samples: none would be left for the background.
  TrainConfig all = c;
  set_config_value(all, "object-samples", std::to_string(c.samples));
  refused(all, "samples");
  // The (x, y, z, t) field has no motion to crowd about: object-motion none turns them off,
  // and asking for them after it is an error.
  set_config_value(c, "object-motion", "none");
  BOOST_TEST(c.object_samples == 0);
  validate(c);
  set_config_value(c, "object-samples", "8");
  refused(c, "object-motion");
}

BOOST_AUTO_TEST_SUITE_END()

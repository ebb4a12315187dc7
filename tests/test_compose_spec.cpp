// The composition spec format: round trip, the instance map, and clear errors.
#include <boost/test/unit_test.hpp>
#include <cmath>

#include "nova/runtime/error.hpp"
#include "nova/io/compose_spec_text.hpp"
#include "scene_test_util.hpp"

using namespace nova;
using namespace nova::test;

BOOST_AUTO_TEST_SUITE(compose_spec)

BOOST_AUTO_TEST_CASE(round_trip) {
  ComposeSpec s;
  s.targets.push_back({"a", 3, true, {{1, -0.25, {10, 20, 30}, {0.1, 0.2, 0.3}, {{1.0 / 3, 0, -2}}},
                                      {2, 0.5, {0, 0, 0}, {0, 0, 0}, {{0, 0, 0}}},
                                      {2, 0.75, {0, 0, 5}, {0, 0, 0}, std::nullopt}}});
  s.targets.push_back({"b", 0, false, {}});
  const ComposeSpec r = parse_compose_spec(format_compose_spec(s), "mem");
  BOOST_TEST(r.targets.size() == 2u);
  BOOST_TEST(r.targets[0].camera == 3);
  BOOST_TEST(!r.targets[1].background);
  const auto& i = r.targets[0].instances[0];
  BOOST_REQUIRE(i.pivot.has_value());
  BOOST_TEST((*i.pivot)[0] == 1.0 / 3);  // exact: written with 17 significant digits
  BOOST_TEST(i.rotate_deg[2] == 30.0);
  BOOST_TEST(r.targets[0].instances[1].object == 2);
  // An explicit origin stays explicit; no pivot stays "not given" (the renderer decides).
  BOOST_REQUIRE(r.targets[0].instances[1].pivot.has_value());
  BOOST_TEST((*r.targets[0].instances[1].pivot)[2] == 0.0);
  BOOST_TEST(!r.targets[0].instances[2].pivot.has_value());
  BOOST_TEST(format_compose_spec(r) == format_compose_spec(s));
}

BOOST_AUTO_TEST_CASE(pivot_is_optional) {
  const ComposeSpec s = parse_compose_spec(
      "nova-compose 1\n"
      "target a camera=0\n"
      "instance object=2 time=0.5 rotate=20,0,10\n"
      "instance object=1 time=0 rotate=0,90,0 pivot=1,-2,0.5\n"
      "instance object=1 time=0 pivot=0,0,0\n",
      "mem");
  const auto& v = s.targets.at(0).instances;
  BOOST_REQUIRE(v.size() == 3u);
  BOOST_TEST(!v[0].pivot.has_value());
  BOOST_REQUIRE(v[1].pivot.has_value());
  BOOST_TEST((*v[1].pivot)[0] == 1.0);
  BOOST_TEST((*v[1].pivot)[1] == -2.0);
  BOOST_TEST((*v[1].pivot)[2] == 0.5);
  BOOST_REQUIRE(v[2].pivot.has_value());
  // Written back: pivot= only where the spec gave one.
  const std::string text = format_compose_spec(s);
  size_t count = 0;
  for (size_t at = text.find("pivot="); at != std::string::npos; at = text.find("pivot=", at + 1)) ++count;
  BOOST_TEST(count == 2u);
  // The explicit pivot is the one instance_transform turns about, exactly as the two-argument
  // form with the same point; an instance without one cannot be placed without a renderer.
  BOOST_TEST(instance_transform(v[1]) == instance_transform(v[1], *v[1].pivot));
  try {
    instance_transform(v[0]);
    BOOST_ERROR("instance_transform without a pivot must throw");
  } catch (const nova::Error& e) {
    BOOST_TEST(e.exit_code() == nova::kExitInternal);
  }
}

BOOST_AUTO_TEST_CASE(instance_map_rotates_about_pivot) {
  ComposeInstance inst{1, 0, {0, 90, 0}, {0, 0, 1}, {{1, 0, 0}}};
  const auto m = instance_transform(inst);
  // The pivot maps to pivot + translate; Ry(90) sends +x to -z.
  BOOST_TEST(std::abs(m[0] * 1 + m[3] - 1) < 1e-12);
  BOOST_TEST(std::abs(m[8] * 1 + m[11] - 1) < 1e-12);
  const double p[3] = {2, 0, 0};  // pivot + x
  BOOST_TEST(std::abs(m[0] * p[0] + m[3] - 1) < 1e-12);
  BOOST_TEST(std::abs(m[8] * p[0] + m[11] - 0) < 1e-12);  // z: -1 from rotation, +1 translate
}

BOOST_AUTO_TEST_CASE(errors_name_file_and_line) {
  expect_error([] { parse_compose_spec("target a camera=0\n", "s.txt"); }, {"s.txt:1", "nova-compose 1"});
  expect_error([] { parse_compose_spec("nova-compose 1\ninstance object=1 time=0\n", "s.txt"); },
               {"s.txt:2", "before any 'target'"});
  expect_error([] { parse_compose_spec("nova-compose 1\ntarget a camera=0\ninstance object=1 time=x\n", "s.txt"); },
               {"s.txt:3", "'time'"});
  expect_error([] { parse_compose_spec("nova-compose 1\ntarget a camera=0\ninstance object=1 time=0 rotate=1,2\n", "s.txt"); },
               {"s.txt:3", "three"});
  expect_error([] { parse_compose_spec("nova-compose 1\ntarget a\n", "s.txt"); }, {"camera=FRAME"});
  expect_error([] { parse_compose_spec("nova-compose 1\ntarget a camera=0\ninstance object=0 time=0\n", "s.txt"); },
               {"object must be >= 1"});
}

BOOST_AUTO_TEST_SUITE_END()

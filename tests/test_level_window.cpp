// The coarse-to-fine window over a rigid object's canonical hash grid
// (canonical-coarse-to-fine): its schedule, and what it does to the field it scales.
#include <boost/test/unit_test.hpp>
#include <cmath>

#include "field_test_util.hpp"
#include "harness.hpp"
#include "nova/graph/executor.hpp"
#include "nova/model/fields.hpp"
#include "nova/runtime/error.hpp"
#include "nova/train/step_graphs.hpp"
#include "nova/train/train_config.hpp"

using namespace nova;
using namespace nova::test;

namespace {

FieldConfig canonical_field() { return small_hash_field(32, ObjectMotion::Rigid); }

// One object's field at 40 fixed canonical points, every parameter from one seed, the
// encoding scaled by `window` (none when empty).
std::vector<float> field_output(const std::vector<float>& window) {
  const size_t M = 40;
  const FieldConfig f = canonical_field();
  Graph g;
  Tensor p = g.input("p", Shape{M, 3});
  Tensor t = g.input("t", Shape{M, 1});
  Tensor w = window.empty() ? Tensor{} : g.input("w", Shape{window.size()});
  Tensor out = build_object_fields(p, t, f, w);
  g.keep(out);
  Executor ex(runtime(), g);
  ex.set(p, random_floats(M * 3, -0.9f, 0.9f, 1));
  ex.set(t, std::vector<float>(M, 0.0f));
  if (w.valid()) ex.set(w, window);
  unsigned seed = 10;
  for (Tensor x : g.parameters()) ex.set(x, random_floats(x.shape().numel(), -1.0f, 1.0f, seed++));
  ex.forward();
  return ex.get(out);
}

}  // namespace

BOOST_AUTO_TEST_SUITE(level_window)

BOOST_AUTO_TEST_CASE(levels_open_from_coarse_to_fine) {
  using V = std::vector<float>;
  BOOST_TEST(nova::level_window(4, 2, 0.0) == (V{1, 1, 0, 0, 0, 0, 0, 0}), boost::test_tools::per_element());
  BOOST_TEST(nova::level_window(4, 2, 1.0) == V(8, 1.0f), boost::test_tools::per_element());
  BOOST_TEST(nova::level_window(4, 2, 7.0) == V(8, 1.0f), boost::test_tools::per_element());
  BOOST_TEST(nova::level_window(4, 1, 0.5) == (V{1, 1, 0, 0}), boost::test_tools::per_element());
  // a = 4 * 0.375 = 1.5: level 1 half open, (1 - cos(pi / 2)) / 2.
  const V mid = nova::level_window(4, 1, 0.375);
  BOOST_TEST(mid[1] == 0.5f, boost::test_tools::tolerance(1e-6f));
  BOOST_TEST(mid[2] == 0.0f);
  // Never decreasing along the levels, never above 1.
  for (double progress : {0.1, 0.3, 0.62, 0.9}) {
    const V w = nova::level_window(16, 2, progress);
    for (size_t i = 2; i < w.size(); ++i) BOOST_TEST((w[i] <= w[i - 2] && w[i] >= 0.0f));
  }
}

BOOST_AUTO_TEST_CASE(an_open_window_is_the_field_and_a_shut_one_sees_no_position) {
  const size_t columns = static_cast<size_t>(canonical_field().hash.outputs());
  const auto plain = field_output({});
  BOOST_TEST(field_output(std::vector<float>(columns, 1.0f)) == plain, boost::test_tools::per_element());
  // Every level shut: the trunk sees zeros, so every point gets the same output.
  const auto shut = field_output(std::vector<float>(columns, 0.0f));
  for (size_t i = 5; i < shut.size(); ++i) BOOST_TEST(shut[i] == shut[i % 5]);
  // The coarsest level only: the output still varies with position.
  const auto coarse = field_output(nova::level_window(4, 2, 0.0));
  bool varies = false;
  for (size_t i = 5; i < coarse.size(); ++i) varies = varies || coarse[i] != coarse[i % 5];
  BOOST_TEST(varies);
}

// The joint step graph takes the window only for a rigid hash-grid field: the frequency
// encoding has no levels, and the (x, y, z, t) field no motion to align.
BOOST_AUTO_TEST_CASE(joint_graph_takes_the_window_for_a_rigid_hash_grid) {
  RayGeometry geo;
  geo.num_objects = 2;
  geo.frames = 6;
  TrainConfig c = preset_config("quick");
  c.rays = 8;
  c.samples = 4;
  BOOST_REQUIRE(c.canonical_coarse_to_fine > 0);
  BOOST_REQUIRE(c.field.motion == ObjectMotion::Rigid);
  const auto joint = build_joint_graph(c, geo);
  BOOST_REQUIRE(joint->level_window.valid());
  BOOST_TEST(joint->level_window.shape().numel() == static_cast<size_t>(c.field.hash.outputs()));
  TrainConfig frequency = c;
  set_config_value(frequency, "encoding", "frequency");
  BOOST_CHECK_NO_THROW(validate(frequency));
  BOOST_TEST(!build_joint_graph(frequency, geo)->level_window.valid());
  TrainConfig paper_field = c;
  set_config_value(paper_field, "object-motion", "none");
  BOOST_TEST(!build_joint_graph(paper_field, geo)->level_window.valid());
  set_config_value(c, "canonical-coarse-to-fine", "0");
  BOOST_TEST(!build_joint_graph(c, geo)->level_window.valid());
}

BOOST_AUTO_TEST_SUITE_END()

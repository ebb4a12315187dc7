// The training step graphs build the loss terms their weights ask for and nothing else: a
// term of weight 0 has no op in the graph, so it costs nothing and cannot leak a gradient.
#include <boost/test/unit_test.hpp>
#include <algorithm>
#include <string>

#include "nova/model/field_graphs.hpp"
#include "nova/train/step_graphs.hpp"
#include "nova/train/train_config.hpp"

using namespace nova;

namespace {

size_t ops_of_type(const Graph& g, const std::string& type) {
  size_t n = 0;
  for (size_t i = 0; i < g.node_count(); ++i) n += g.node(static_cast<int>(i)).type() == type;
  return n;
}

bool has_term(const StepGraph& s, const std::string& name) {
  return std::any_of(s.terms.begin(), s.terms.end(), [&](const auto& t) { return t.first == name; });
}

TrainConfig small_config() {
  TrainConfig c = preset_config("quick");
  c.rays = 8;
  c.samples = 6;
  c.occupancy = false;
  return c;
}

RayGeometry two_objects() {
  RayGeometry g;
  g.ndc = true;
  g.num_objects = 2;
  return g;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(step_graphs)

BOOST_AUTO_TEST_CASE(distortion_term_only_when_weighted) {
  TrainConfig c = small_config();
  c.w_distortion = 0.0f;
  auto joint = build_joint_graph(c, two_objects());
  BOOST_TEST(ops_of_type(joint->graph, "distortion_loss") == 0u);
  BOOST_TEST(!has_term(*joint, "distortion"));

  c.w_distortion = 0.01f;
  joint = build_joint_graph(c, two_objects());
  BOOST_TEST(ops_of_type(joint->graph, "distortion_loss") == 1u);
  BOOST_TEST(has_term(*joint, "distortion"));
  // The static NeRF takes no part: pretraining has no distortion term at any weight.
  auto pretrain = build_pretrain_graph(c, two_objects());
  BOOST_TEST(ops_of_type(pretrain->graph, "distortion_loss") == 0u);
}

BOOST_AUTO_TEST_CASE(free_space_term_needs_weight_and_disparity) {
  TrainConfig c = small_config();
  c.w_depth = 0.0f;
  c.w_free_space = 1.0f;
  RayGeometry geo = two_objects();
  auto joint = build_joint_graph(c, geo);  // no disparity maps: nothing to place the surface
  BOOST_TEST(ops_of_type(joint->graph, "free_space_loss") == 0u);
  BOOST_TEST(!joint->target_depth.valid());
  geo.disparity = true;
  joint = build_joint_graph(c, geo);
  BOOST_TEST(ops_of_type(joint->graph, "free_space_loss") == 1u);
  BOOST_TEST(ops_of_type(joint->graph, "depth_loss") == 0u);  // w-depth 0: its own term stays out
  BOOST_TEST(joint->target_depth.valid());
  BOOST_TEST(has_term(*joint, "free_space"));
  // The static NeRF takes no part: pretraining has no free-space term.
  BOOST_TEST(ops_of_type(build_pretrain_graph(c, geo)->graph, "free_space_loss") == 0u);
  c.w_free_space = 0.0f;
  BOOST_TEST(ops_of_type(build_joint_graph(c, geo)->graph, "free_space_loss") == 0u);
}

BOOST_AUTO_TEST_CASE(zero_weight_terms_are_not_built) {
  TrainConfig c = small_config();
  c.weights.sparsity = 0.0f;
  c.weights.blending = 0.0f;
  auto joint = build_joint_graph(c, two_objects());
  BOOST_TEST(ops_of_type(joint->graph, "sparsity_loss") == 0u);
  BOOST_TEST(ops_of_type(joint->graph, "blending_loss") == 0u);
  BOOST_TEST(ops_of_type(joint->graph, "alpha_loss") == 1u);
  c.weights.sparsity = 0.1f;
  joint = build_joint_graph(c, two_objects());
  BOOST_TEST(ops_of_type(joint->graph, "sparsity_loss") == 1u);
}

BOOST_AUTO_TEST_SUITE_END()

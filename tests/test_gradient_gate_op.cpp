// The gradient gate: refused shapes, and what it is for: with static-background-only the
// joint step sends no gradient to the static NeRF from rays of object pixels (with
// static-blend-from-objects, none to its colour). Its forward (an
// exact copy), its gated backward against float64 (also accumulating into an input read
// ungated) and the all-ones gate's finite differences are the op table's gradient_gate entry
// (tests/op_table_core.cpp).
#include <boost/test/unit_test.hpp>
#include <cmath>
#include <string>

#include "harness.hpp"
#include "nova/graph/executor.hpp"
#include "nova/model/field_graphs.hpp"
#include "nova/ops/tensor/tensor_ops.hpp"
#include "nova/sampling/rays.hpp"
#include "nova/train/step_graphs.hpp"
#include "nova/train/train_config.hpp"

using namespace nova;
using nova::test::random_floats;

namespace {

// Sum of |gradient| over the parameters whose name starts with `prefix`, after one joint
// step on random rays whose target masks are `masks` ([3, R]).
double joint_gradient_mass(bool gate, const std::vector<float>& masks, const std::string& prefix,
                           bool blend_from_objects = false) {
  TrainConfig c = preset_config("quick");
  c.rays = 8;
  c.samples = 6;
  c.occupancy = false;
  c.static_background_only = gate;
  c.static_blend_from_objects = blend_from_objects;
  RayGeometry geo;
  geo.ndc = true;
  geo.num_objects = 2;
  auto s = build_joint_graph(c, geo);
  Executor ex(test::runtime(), s->graph);
  const size_t R = 8;
  Camera cam;
  cam.width = 32;
  cam.height = 24;
  cam.fx = cam.fy = 30;
  cam.cx = 16;
  cam.cy = 12;
  std::vector<float> pixels;
  for (size_t r = 0; r < R; ++r) pixels.push_back(float(3 * r + 2)), pixels.push_back(float(2 * r + 3));
  ex.set(s->pixels, pixels);
  ex.set(s->cameras, camera_rows({cam, cam, cam}));
  s->draws->value = 11;
  ex.set(s->times, std::vector<float>(2, 0.25f));
  ex.set(s->target_rgb, random_floats(R * 3, 0, 1, 12));
  ex.set(s->target_masks, masks);
  if (s->level_window.valid()) ex.set(s->level_window, std::vector<float>(s->level_window.shape().numel(), 1.0f));
  ex.forward();
  ex.backward();
  double mass = 0;
  for (Tensor p : s->graph.parameters())
    if (p.info().name.rfind(prefix, 0) == 0)
      for (float v : ex.get_grad(p)) mass += std::fabs(v);
  return mass;
}

// Masks [3, R]: ray r is background when background[r], else object 1.
std::vector<float> masks_of(const std::vector<bool>& background) {
  const size_t R = background.size();
  std::vector<float> m(3 * R, 0.0f);
  for (size_t r = 0; r < R; ++r) m[(background[r] ? 0 : 1) * R + r] = 1.0f;
  return m;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(gradient_gate_op)

BOOST_AUTO_TEST_CASE(bad_shapes_are_refused) {
  Graph g;
  Tensor x = g.input("x", Shape{10, 3}, true), gate = g.input("gate", Shape{2, 4});
  BOOST_CHECK_THROW(gradient_gate(x, gate, 0), Error);  // 10 rows are not a multiple of 4 rays
  Tensor gate5 = g.input("gate5", Shape{2, 5});
  BOOST_CHECK_THROW(gradient_gate(x, gate5, 2), Error);  // no row 2
  BOOST_CHECK_NO_THROW(gradient_gate(x, gate5, 1));
}

BOOST_AUTO_TEST_CASE(static_nerf_learns_from_background_rays_only) {
  const std::vector<bool> objects_only(8, false);
  const std::vector<bool> mixed{true, false, false, true, false, false, false, true};
  // Gated: object rays send the static NeRF nothing, background rays do.
  BOOST_TEST(joint_gradient_mass(true, masks_of(objects_only), "static.") == 0.0);
  BOOST_TEST(joint_gradient_mass(true, masks_of(mixed), "static.") > 0.0);
  // Ungated, object rays reach it (the reference's behaviour); the object NeRFs learn either way.
  BOOST_TEST(joint_gradient_mass(false, masks_of(objects_only), "static.") > 0.0);
  BOOST_TEST(joint_gradient_mass(true, masks_of(objects_only), "objects.") > 0.0);
}

BOOST_AUTO_TEST_CASE(static_blend_learns_from_object_rays_when_asked) {
  const std::vector<float> objects_only = masks_of(std::vector<bool>(8, false));
  // The colour head sees only the gated colour columns; the blend reaches its head (and, through
  // it, the shared trunk) from object rays too.
  BOOST_TEST(joint_gradient_mass(true, objects_only, "static.rgb", true) == 0.0);
  BOOST_TEST(joint_gradient_mass(true, objects_only, "static.view", true) == 0.0);
  BOOST_TEST(joint_gradient_mass(true, objects_only, "static.sigma_blend", true) > 0.0);
  BOOST_TEST(joint_gradient_mass(true, objects_only, "static.sigma_blend", false) == 0.0);
}

BOOST_AUTO_TEST_SUITE_END()

// The gradient gate: an exact copy forward, a per-ray scaled gradient backward (against a
// float64 reference), the identity's finite differences with an all-ones gate, and what it is
// for: with static-background-only the joint step sends no gradient to the static NeRF from
// rays of object pixels.
//
// Tolerances: the forward is a copy (exact). The backward is one float32 product per element
// plus, where x is also used directly, one addition: rtol 1e-5 with atol 1e-7 covers both.
#include <boost/test/unit_test.hpp>
#include <cmath>
#include <string>

#include "harness.hpp"
#include "nova/executor.hpp"
#include "nova/nova_graphs.hpp"
#include "nova/ops.hpp"
#include "nova/rays.hpp"
#include "nova/step_graphs.hpp"
#include "nova/train_config.hpp"

using namespace nova;
using nova::test::check_gradients;
using nova::test::expect_close;
using nova::test::OpUnderTest;
using nova::test::random_floats;

namespace {

// Gate values 0, 1 and soft ones, row by row.
std::vector<float> mixed_gate(size_t n, unsigned seed) {
  auto g = random_floats(n, 0, 1, seed);
  for (float& v : g) v = v < 0.35f ? 0.0f : v < 0.7f ? 1.0f : v;
  return g;
}

// Sum of |gradient| over the parameters whose name starts with `prefix`, after one joint
// step on random rays whose target masks are `masks` ([3, R]).
double joint_gradient_mass(bool gate, const std::vector<float>& masks, const std::string& prefix) {
  TrainConfig c = preset_config("quick");
  c.rays = 8;
  c.samples = 6;
  c.occupancy = false;
  c.static_background_only = gate;
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

BOOST_AUTO_TEST_CASE(copy_forward_gated_backward) {
  const size_t R = 13, G = 3, C = 5;
  const auto x = random_floats(R * G * C, -1, 1, 1), t = random_floats(R * G * C, -1, 1, 2);
  const auto t2 = random_floats(R * G * C, -1, 1, 3);
  const auto gate = mixed_gate(2 * R, 4);
  Graph g;
  Tensor tx = g.input("x", Shape{R * G, C}, true), tg = g.input("gate", Shape{2, R});
  Tensor tt = g.input("t", Shape{R * G, C}), tt2 = g.input("t2", Shape{R * G, C});
  Tensor y = gradient_gate(tx, tg, 1);
  g.keep(y);
  // x is also used ungated, so the gate's backward accumulates into x's gradient.
  g.set_loss(weighted_sum({mse(y, tt), mse(tx, tt2)}, {1.0f, 1.0f}));
  Executor ex(test::runtime(), g);
  ex.set(tx, x);
  ex.set(tg, gate);
  ex.set(tt, t);
  ex.set(tt2, t2);
  ex.forward();
  ex.backward();
  expect_close(ex.get(y), test::to_double(x), 0, 0, "the forward is an exact copy");
  const double n = static_cast<double>(R * G * C);
  std::vector<double> ref(x.size());
  for (size_t i = 0; i < x.size(); ++i) {
    const size_t ray = i / C / G;
    ref[i] = 2.0 * (double(x[i]) - t[i]) / n * gate[R + ray] + 2.0 * (double(x[i]) - t2[i]) / n;
  }
  expect_close(ex.get_grad(tx), ref, 1e-7, 1e-5, "d loss / d x through the gate (row 1)");
}

BOOST_AUTO_TEST_CASE(all_ones_gate_is_the_identity_for_finite_differences) {
  const size_t R = 7, G = 4, C = 3;
  const auto build = [&](Graph& g) {
    Tensor tx = g.input("x", Shape{R * G, C}, true), tg = g.input("gate", Shape{1, R});
    return OpUnderTest{{tx, tg}, gradient_gate(tx, tg, 0)};
  };
  check_gradients(build, {random_floats(R * G * C, -1, 1, 5), std::vector<float>(R, 1.0f)});
}

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

BOOST_AUTO_TEST_SUITE_END()

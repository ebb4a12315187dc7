// The executor's debug mode (ExecutorOptions::check_finite) stops at the first NaN or Inf,
// naming the op and the tensor.
#include <boost/test/unit_test.hpp>
#include <cmath>
#include <limits>

#include "harness.hpp"
#include "nova/loss/terms.hpp"
#include "nova/render/render_composite.hpp"

using namespace nova;
using namespace nova::test;

BOOST_AUTO_TEST_SUITE(check_finite)

// Finite inputs whose squared difference overflows float32: masked_mse's forward writes Inf.
BOOST_AUTO_TEST_CASE(names_the_op_and_tensor_of_the_first_non_finite_value) {
  Graph g;
  Tensor pred = g.input("pred", Shape{4, 3}, true), target = g.input("target", Shape{4, 3}),
         mask = g.input("mask", Shape{4});
  Tensor loss = masked_mse(pred, target, mask);
  g.set_loss(loss);
  for (bool check : {false, true}) {
    ExecutorOptions o;
    o.check_finite = check;
    Executor ex(runtime(), g, o);
    std::vector<float> p(12, 0.5f), t(12, 0.25f), m(4, 1.0f);
    p[7] = 3e38f;
    t[7] = -3e38f;
    ex.set(pred, p);
    ex.set(target, t);
    ex.set(mask, m);
    if (!check) {
      ex.forward();  // without the debug mode the Inf passes silently
      BOOST_TEST(!std::isfinite(ex.loss()));
      continue;
    }
    try {
      ex.forward();
      BOOST_FAIL("check_finite did not fire");
    } catch (const Error& e) {
      const std::string msg = e.what();
      BOOST_TEST_MESSAGE("check_finite: " << msg);
      BOOST_TEST(msg.find("masked_mse") != std::string::npos, msg);
      BOOST_TEST(msg.find("'" + loss.info().name + "'") != std::string::npos, msg);
      BOOST_TEST(msg.find("forward") != std::string::npos, msg);
    }
  }
}

BOOST_AUTO_TEST_CASE(fires_in_the_backward_pass_too) {
  // A finite forward whose gradient overflows: with a spacing of 3e38, d alpha / d sigma =
  // delta exp(-sigma delta) is about 1.5e37 at sigma = 1e-38, and the loss weight 1e6 pushes
  // d loss / d sigma past float32's range while every forward value stays finite.
  Graph g;
  Tensor raw = g.input("raw", Shape{2, 5}, true), delta = g.input("delta", Shape{1, 2}),
         z = g.input("z", Shape{1, 2}), target = g.input("target", Shape{1, 3});
  RenderOutputs out = render_composite(raw, delta, z);
  g.set_loss(weighted_sum({mse(out.rgb, target)}, {1e6f}));
  ExecutorOptions o;
  o.check_finite = true;
  Executor ex(runtime(), g, o);
  ex.set(raw, {0, 0, 0, 1e-38f, 0, 0, 0, 0, -1, 0});
  ex.set(delta, {3e38f, 3e38f});
  ex.set(z, {0.5f, 1.0f});
  ex.set(target, {1, 1, 1});
  ex.forward();
  BOOST_TEST(std::isfinite(ex.loss()));
  try {
    ex.backward();
    BOOST_FAIL("check_finite did not fire in the backward");
  } catch (const Error& e) {
    const std::string msg = e.what();
    BOOST_TEST_MESSAGE("check_finite: " << msg);
    BOOST_TEST(msg.find("render_composite") != std::string::npos, msg);
    BOOST_TEST(msg.find("gradient of 'raw'") != std::string::npos, msg);
    BOOST_TEST(msg.find("backward") != std::string::npos, msg);
  }
}

BOOST_AUTO_TEST_CASE(rejects_non_finite_inputs) {
  Graph g;
  Tensor x = g.input("x", Shape{3}, true), t = g.input("t", Shape{3});
  g.set_loss(mse(x, t));
  ExecutorOptions o;
  o.check_finite = true;
  Executor ex(runtime(), g, o);
  ex.set(x, {0.0f, std::numeric_limits<float>::quiet_NaN(), 1.0f});
  ex.set(t, {0.0f, 0.0f, 0.0f});
  try {
    ex.forward();
    BOOST_FAIL("check_finite did not fire on a NaN input");
  } catch (const Error& e) {
    BOOST_TEST(std::string(e.what()).find("'x'") != std::string::npos, e.what());
  }
}

BOOST_AUTO_TEST_SUITE_END()

// render_composite's and stack's refused shapes, and stack's shape. Their values and gradients
// against float64 (render_composite: 1 to 8 NeRFs, 5 or 7 channels, a delta per NeRF, noise,
// activated inputs, soft and hard blending, the device's own central differences) are the op
// table's render_composite and concat entries (tests/op_table_render.cpp, op_table_core.cpp).
#include <boost/test/unit_test.hpp>

#include "harness.hpp"
#include "nova/render/render_composite.hpp"

using namespace nova;
using namespace nova::test;

BOOST_AUTO_TEST_SUITE(render)

// stack's values and gradients are the op table's concat entry (a stack of two parts).
BOOST_AUTO_TEST_CASE(stack_shape) {
  Graph g;
  Tensor ta = g.input("a", Shape{6, 5}), tb = g.input("b", Shape{2, 6, 5});
  BOOST_TEST(stack({ta, tb}).shape().str() == "[3, 6, 5]");
}

BOOST_AUTO_TEST_CASE(rejects_bad_shapes) {
  Graph g;
  Tensor raw = g.input("raw", Shape{2, 32, 4});
  Tensor delta = g.input("delta", Shape{2, 16}), z = g.input("z", Shape{2, 16});
  BOOST_CHECK_THROW(render_composite(raw, delta, z), Error);
  Tensor raw5 = g.input("raw5", Shape{2, 32, 5});
  Tensor dgrad = g.input("dgrad", Shape{2, 16}, true);
  BOOST_CHECK_THROW(render_composite(raw5, dgrad, z), Error);
  Tensor zbad = g.input("zbad", Shape{3, 16});
  BOOST_CHECK_THROW(render_composite(raw5, delta, zbad), Error);
}

BOOST_AUTO_TEST_SUITE_END()

// render_composite and stack against the float64 reference, with gradients checked both
// against float64 finite differences and with the harness's float32 device FD check.
#include <boost/test/unit_test.hpp>

#include "harness.hpp"
#include "nova/render.hpp"
#include "render_check.hpp"

using namespace nova;
using namespace nova::test;

BOOST_AUTO_TEST_SUITE(render)

// Forward tolerance: atol 2e-6, rtol 1e-5. Each output is a sum of at most S * N float32
// products of values in [0, 1], each with relative rounding about 1e-7, and a transmittance
// that is itself a product of S factors (relative error about S * 6e-8 = 4e-6 at S = 64):
// 1e-5 relative plus 2e-6 absolute covers that with margin while still catching any
// formula slip (a wrong epsilon or normalisation moves outputs by 1e-3 or more).
// Gradient tolerance: rtol 1e-3, atol 1e-4 of the gradient scale: the backward has
// cancellations (R_s - G, g_n . c - R_n) of sums of up to S terms, so its float32 error is
// about S * 1e-7 relative to the gradient scale; FD in float64 is accurate to ~1e-9.
BOOST_AUTO_TEST_CASE(matches_float64_reference) {
  struct Config {
    int nerfs, channels;
    bool per_nerf_delta, noise;
  };
  const Config configs[] = {{1, 5, false, false}, {2, 5, true, true}, {4, 7, false, true},
                            {8, 5, true, false}};
  unsigned seed = 11;
  for (const Config& c : configs) {
    const std::string what = "N=" + std::to_string(c.nerfs) + " C=" + std::to_string(c.channels);
    const RenderRefInput in = random_render_case(c.nerfs, 3, 64, c.channels, c.per_nerf_delta, c.noise, seed);
    const RenderTargets t = random_targets(in, seed + 100);
    const DeviceRender d = run_device_render(in, t);
    expect_forward_close(d, in, 2e-6, 1e-5, what);
    expect_gradient_close(d, in, t, 1e-4, 1e-3, what);
    // Channels past the fifth take a zero gradient.
    for (size_t e = 5; e < d.grad_raw.size(); e += c.channels)
      for (int k = 5; k < c.channels; ++k) BOOST_TEST(d.grad_raw[e - 5 + k] == 0.0f);
    seed += 10;
  }
}

BOOST_AUTO_TEST_CASE(activated_inputs_and_hard_blending) {
  // Already activated inputs (rgb and blend in [0, 1]); blends kept away from the 0.5
  // threshold (it is a step) so finite differences never cross it.
  RenderRefInput in = random_render_case(3, 3, 32, 5, false, false, 5);
  const auto u = random_floats(in.raw.size(), 0, 1, 6);
  for (size_t e = 0; e < in.raw.size(); ++e) {
    const size_t ch = e % 5;
    if (ch < 3) in.raw[e] = u[e];
    if (ch == 4) in.raw[e] = u[e] < 0.5f ? u[e] * 0.8 : 0.6 + 0.4 * (u[e] - 0.5f) * 2;
  }
  in.rgb_sigmoid = in.blend_sigmoid = false;
  for (bool hard : {false, true}) {
    in.hard_blend = hard;
    const RenderTargets t = random_targets(in, 77);
    const DeviceRender d = run_device_render(in, t);
    const std::string what = hard ? "hard blending" : "soft blending";
    expect_forward_close(d, in, 2e-6, 1e-5, what);
    expect_gradient_close(d, in, t, 1e-4, 1e-3, what);
  }
}

// The harness's check: float32 central differences of the device forward itself, one output
// at a time (harness default tolerance 2e-2 of the gradient scale with step 1e-2: the FD
// truncation error h^2 f''' / 6 is about 2e-5 and the float32 rounding of the loss
// difference about 1e-7 / 2e-2 = 5e-6 of it, so 2e-2 leaves room without hiding an error).
BOOST_AUTO_TEST_CASE(device_finite_differences) {
  const RenderRefInput in = random_render_case(2, 2, 16, 5, true, false, 3);
  for (int output = 0; output < 5; ++output) {
    const BuildFn build = [&](Graph& g) {
      Tensor raw = g.input("raw", Shape{2, 32, 5}, true);
      Tensor delta = g.input("delta", Shape{2, 2, 16});
      Tensor z = g.input("z", Shape{2, 16});
      RenderOutputs o = render_composite(raw, delta, z);
      const Tensor outs[] = {o.rgb, o.nerf_rgb, o.mask, o.depth, o.acc};
      return OpUnderTest{{raw, delta, z}, outs[output]};
    };
    const double worst = check_gradients(build, {to_float(in.raw), to_float(in.delta), to_float(in.z)});
    BOOST_TEST_MESSAGE("render output " << output << ": worst FD error " << worst);
  }
}

BOOST_AUTO_TEST_CASE(stack_values_and_gradients) {
  // Exact copies: values must match bit for bit; the gradient FD check is then trivial but
  // proves the split of the upstream gradient (tolerance: harness default).
  const auto a = random_floats(6 * 5, -1, 1, 1), b = random_floats(2 * 6 * 5, -1, 1, 2);
  Graph g;
  Tensor ta = g.input("a", Shape{6, 5}), tb = g.input("b", Shape{2, 6, 5});
  Tensor s = stack({ta, tb});
  BOOST_TEST(s.shape().str() == "[3, 6, 5]");
  g.keep(s);
  Executor ex(runtime(), g);
  ex.set(ta, a);
  ex.set(tb, b);
  ex.forward();
  std::vector<float> expected = a;
  expected.insert(expected.end(), b.begin(), b.end());
  BOOST_TEST(ex.get(s) == expected, boost::test_tools::per_element());
  check_gradients(
      [](Graph& gg) {
        Tensor x = gg.input("a", Shape{6, 5}, true), y = gg.input("b", Shape{2, 6, 5}, true);
        return OpUnderTest{{x, y}, stack({x, y})};
      },
      {a, b});
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

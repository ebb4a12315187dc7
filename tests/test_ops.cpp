// The MLP built from the ops (each op alone is an entry of the op table, tests/op_table_core.cpp
// and tests/op_table_losses.cpp: forward against float64, gradients by central differences):
// a tensor read twice, the skip connection's two gradient paths, batched against separate
// networks, and the optimiser.
//
// Tolerances: gradient checks use the harness default: error normalised by the gradient's
// largest magnitude <= 2e-2, which covers the O(h^2) truncation and the float32 rounding of
// the loss divided by h, and catches a wrong or missing term.
#include <boost/test/unit_test.hpp>
#include <cmath>

#include "harness.hpp"
#include "nova/model/mlp.hpp"
#include "nova/ops/linalg/dense.hpp"
#include "nova/ops/tensor/tensor_ops.hpp"
#include "nova/loss/terms.hpp"
#include "nova/train/optim.hpp"

using namespace nova;
using nova::test::check_gradients;
using nova::test::expect_close;
using nova::test::OpUnderTest;
using nova::test::random_floats;

BOOST_AUTO_TEST_SUITE(ops)

BOOST_AUTO_TEST_CASE(gradient_of_a_tensor_read_twice_is_summed) {
  // concat(x, x): the second slot must add to the first slot's gradient, not overwrite it.
  check_gradients(
      [](Graph& g) {
        Tensor x = g.input("x", Shape{7, 4}, true);
        return OpUnderTest{{x}, concat({x, x})};
      },
      {random_floats(28, -1, 1, 61)});
}

BOOST_AUTO_TEST_CASE(mlp_with_skip_gradient_wrt_input) {
  // The input feeds both the first layer and the skip concatenation: two gradient paths.
  MlpConfig c;
  c.depth = 3;
  c.width = 8;
  c.skip = 1;
  c.outputs = 2;
  c.output_activation = Activation::Sigmoid;
  test::GradCheckOptions o;
  o.step = 3e-3f;
  check_gradients(
      [&](Graph& g) {
        Tensor x = g.input("x", Shape{9, 5}, true);
        return OpUnderTest{{x}, build_mlp(x, c).output};
      },
      {random_floats(45, -1, 1, 91)}, o);
}

BOOST_AUTO_TEST_CASE(batched_networks_match_separate_networks) {
  // Two networks stacked in the batch dimension (one batched GEMM per layer) against each
  // network built alone with the same weights: outputs and weight gradients must agree to
  // float32 rounding (the same products, possibly summed in another order by the GEMM tiles).
  const size_t rows = 31, in = 7, nets = 2;
  MlpConfig c;
  c.depth = 3;
  c.width = 16;
  c.skip = 1;
  c.outputs = 3;
  const auto x = random_floats(nets * rows * in, -1, 1, 301);
  const auto t = random_floats(nets * rows * c.outputs, 0, 1, 302);

  MlpConfig cb = c;
  cb.networks = static_cast<int>(nets);
  Graph gb;
  Tensor xb = gb.input("x", Shape{nets, rows, in});
  Tensor tb = gb.input("t", Shape{nets, rows, static_cast<size_t>(c.outputs)});
  const Mlp mb = build_mlp(xb, cb);
  gb.keep(mb.output);
  gb.set_loss(mse(mb.output, tb));
  Executor eb(test::runtime(), gb);
  eb.set(xb, x);
  eb.set(tb, t);
  eb.forward();
  eb.backward();
  const auto yb = eb.get(mb.output);

  for (size_t n = 0; n < nets; ++n) {
    Graph g;
    Tensor xs = g.input("x", Shape{rows, in});
    Tensor ts = g.input("t", Shape{rows, static_cast<size_t>(c.outputs)});
    const Mlp ms = build_mlp(xs, c);
    g.keep(ms.output);
    g.set_loss(mse(ms.output, ts));
    Executor es(test::runtime(), g);
    const auto slice = [&](const std::vector<float>& v, size_t per) {
      return std::vector<float>(v.begin() + n * per, v.begin() + (n + 1) * per);
    };
    const std::vector<Tensor> pb = gb.parameters(), ps = g.parameters();
    BOOST_REQUIRE_EQUAL(pb.size(), ps.size());
    for (size_t i = 0; i < ps.size(); ++i)
      es.set(ps[i], slice(eb.get(pb[i]), ps[i].shape().numel()));
    es.set(xs, slice(x, rows * in));
    es.set(ts, slice(t, rows * c.outputs));
    es.forward();
    es.backward();
    expect_close(es.get(ms.output), test::to_double(slice(yb, rows * c.outputs)), 1e-6, 1e-5,
                 "network " + std::to_string(n) + " output");
    // The batched loss is the mean over both networks: its gradients are half the single ones.
    for (size_t i = 0; i < ps.size(); ++i) {
      std::vector<double> half;
      for (float v : es.get_grad(ps[i])) half.push_back(0.5 * v);
      expect_close(slice(eb.get_grad(pb[i]), ps[i].shape().numel()), half, 1e-6, 1e-4,
                   "gradient of " + ps[i].info().name);
    }
  }
}

BOOST_AUTO_TEST_CASE(adam_matches_reference) {
  Runtime& rt = test::runtime();
  const size_t n = 1000;
  auto p = random_floats(n, -1, 1, 101);
  Buffer dp = rt.upload_floats(p);
  Adam adam(rt, n);
  std::vector<double> ref(p.begin(), p.end()), m(n, 0), v(n, 0);
  const double b1 = 0.9, b2 = 0.999, eps = 1e-8;
  for (int t = 1; t <= 5; ++t) {
    const auto g = random_floats(n, -1, 1, 200 + t);
    Buffer dg = rt.upload_floats(g);
    const float lr = 1e-2f / t;
    adam.step(dp.get(), dg.get(), lr);
    for (size_t i = 0; i < n; ++i) {
      m[i] = b1 * m[i] + (1 - b1) * g[i];
      v[i] = b2 * v[i] + (1 - b2) * g[i] * g[i];
      const double mh = m[i] / (1 - std::pow(b1, t)), vh = v[i] / (1 - std::pow(b2, t));
      ref[i] -= static_cast<double>(lr) * mh / (std::sqrt(vh) + eps);
    }
  }
  // Each update moves a parameter by <= lr (Adam's step is bounded by ~lr); float32 rounding
  // of five updates on values ~1 stays under 1e-6.
  expect_close(rt.download_floats(dp.get(), n), ref, 2e-6, 1e-6, "adam");
  BOOST_TEST(adam.steps() == 5);
}

BOOST_AUTO_TEST_CASE(learning_rate_schedule) {
  ExponentialDecay s;
  s.lr0 = 5e-4f;
  s.decay_steps = 300000;
  BOOST_TEST(s(0) == 5e-4f);
  BOOST_TEST(std::fabs(s(300000) - 5e-5f) < 1e-9f);
  BOOST_TEST(std::fabs(s(150000) - 5e-4f * std::sqrt(0.1f)) < 1e-8f);
}

BOOST_AUTO_TEST_SUITE_END()

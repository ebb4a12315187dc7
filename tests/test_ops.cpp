// Every MLP op against a float64 host reference (forward) and central finite differences of
// the device forward (backward).
//
// Tolerances: forward outputs of elementwise ops are within a few float32 ulps of the float64
// value (one rounding of the input sum, <= 4 ulp for exp/log1p/sin/cos in OpenCL's full
// profile), so rtol 1e-5 with a small atol for values near 0 holds with margin while any
// formula error (O(1e-2) or more) fails. Gradient checks use the harness default: error
// normalised by the gradient's largest magnitude <= 2e-2, which covers the O(h^2) truncation
// and the float32 rounding of the loss divided by h, and catches a wrong or missing term.
#include <boost/test/unit_test.hpp>
#include <cmath>

#include "harness.hpp"
#include "nova/mlp.hpp"
#include "nova/ops.hpp"
#include "nova/optim.hpp"

using namespace nova;
using nova::test::check_gradients;
using nova::test::expect_close;
using nova::test::OpUnderTest;
using nova::test::random_floats;
using nova::test::run_forward;

namespace {

const Activation kActivations[] = {Activation::Identity, Activation::ReLU, Activation::Sigmoid,
                                   Activation::Softplus};

}  // namespace

BOOST_AUTO_TEST_SUITE(ops)

BOOST_AUTO_TEST_CASE(positional_encoding_forward) {
  const size_t rows = 37, dims = 3;
  const int freqs = 10;
  const auto p = random_floats(rows * dims, -1.5f, 1.5f, 11);
  const auto out = run_forward(
      [&](Graph& g) {
        Tensor x = g.input("p", Shape{rows, dims});
        return OpUnderTest{{x}, positional_encoding(x, freqs)};
      },
      {p});
  std::vector<double> ref;
  for (size_t r = 0; r < rows; ++r) {
    for (size_t d = 0; d < dims; ++d) ref.push_back(p[r * dims + d]);
    for (int k = 0; k < freqs; ++k) {
      for (size_t d = 0; d < dims; ++d) ref.push_back(std::sin(std::ldexp(p[r * dims + d], k)));
      for (size_t d = 0; d < dims; ++d) ref.push_back(std::cos(std::ldexp(p[r * dims + d], k)));
    }
  }
  // sin/cos of arguments up to 768: <= 4 ulp of a value <= 1, so atol 1e-6.
  expect_close(out, ref, 1e-6, 1e-6, "positional encoding");
}

BOOST_AUTO_TEST_CASE(positional_encoding_gradient) {
  // L = 4: the highest band, sin(8x), keeps the O(h^2 * 8^3) truncation error small at h=1e-3.
  test::GradCheckOptions o;
  o.step = 1e-3f;
  check_gradients(
      [](Graph& g) {
        Tensor x = g.input("p", Shape{11, 3}, true);
        return OpUnderTest{{x}, positional_encoding(x, 4)};
      },
      {random_floats(33, -1, 1, 5)}, o);
}

BOOST_AUTO_TEST_CASE(bias_act_forward) {
  for (Activation a : kActivations) {
    for (size_t batch : {1, 3}) {
      const size_t rows = 29, cols = 17;
      const auto h = random_floats(batch * rows * cols, -4, 4, 21);
      const auto b = random_floats(batch * cols, -1, 1, 22);
      const auto out = run_forward(
          [&](Graph& g) {
            Tensor th = g.input("h", batch > 1 ? Shape{batch, rows, cols} : Shape{rows, cols});
            Tensor tb = g.input("b", batch > 1 ? Shape{batch, cols} : Shape{cols});
            return OpUnderTest{{th, tb}, bias_act(th, tb, a)};
          },
          {h, b});
      std::vector<double> ref(h.size());
      for (size_t i = 0; i < h.size(); ++i)
        ref[i] = test::activation_reference(a, static_cast<double>(h[i]) + b[(i / (rows * cols)) * cols + i % cols]);
      expect_close(out, ref, 1e-6, 1e-5, std::string("bias_") + activation_name(a));
    }
  }
}

BOOST_AUTO_TEST_CASE(bias_act_gradient) {
  for (Activation a : kActivations) {
    for (size_t batch : {1, 2}) {
      const size_t rows = 13, cols = 7;
      auto b = random_floats(batch * cols, -0.5f, 0.5f, 31);
      auto h = random_floats(batch * rows * cols, -2, 2, 32);
      // Keep h + b at least 0.05 from ReLU's kink (the stencil moves it by 1e-2).
      for (size_t i = 0; i < h.size(); ++i) {
        const float bias = b[(i / (rows * cols)) * cols + i % cols];
        const float s = h[i] + bias;
        if (std::fabs(s) < 0.05f) h[i] = (s >= 0 ? 0.05f : -0.05f) - bias;
      }
      BOOST_TEST_CONTEXT(activation_name(a) << " batch " << batch) {
        check_gradients(
            [&](Graph& g) {
              Tensor th = g.input("h", batch > 1 ? Shape{batch, rows, cols} : Shape{rows, cols}, true);
              Tensor tb = g.input("b", batch > 1 ? Shape{batch, cols} : Shape{cols}, true);
              return OpUnderTest{{th, tb}, bias_act(th, tb, a)};
            },
            {h, b});
      }
    }
  }
}

BOOST_AUTO_TEST_CASE(linear_forward_and_gradient) {
  for (size_t batch : {1, 2}) {
    const size_t m = 23, k = 9, n = 5;
    const auto x = random_floats(batch * m * k, -1, 1, 41);
    const auto w = random_floats(batch * k * n, -1, 1, 42);
    const auto build = [&](Graph& g) {
      Tensor tx = g.input("x", batch > 1 ? Shape{batch, m, k} : Shape{m, k}, true);
      Tensor tw = g.input("w", batch > 1 ? Shape{batch, k, n} : Shape{k, n}, true);
      return OpUnderTest{{tx, tw}, linear(tx, tw)};
    };
    const auto out = run_forward(build, {x, w});
    std::vector<double> ref(batch * m * n, 0.0);
    for (size_t p = 0; p < batch; ++p)
      for (size_t i = 0; i < m; ++i)
        for (size_t j = 0; j < n; ++j)
          for (size_t l = 0; l < k; ++l)
            ref[p * m * n + i * n + j] +=
                static_cast<double>(x[p * m * k + i * k + l]) * w[p * k * n + l * n + j];
    // k = 9 products of values in [-1, 1]: |err| <= 2 * 9 * 2^-24 * 9 < 1e-5.
    expect_close(out, ref, 1e-5, 0, "linear batch " + std::to_string(batch));
    check_gradients(build, {x, w});
  }
}

BOOST_AUTO_TEST_CASE(concat_forward_and_gradient) {
  const auto a = random_floats(13 * 3, -1, 1, 51), b = random_floats(13 * 5, -1, 1, 52);
  const auto build = [](Graph& g) {
    Tensor ta = g.input("a", Shape{13, 3}, true), tb = g.input("b", Shape{13, 5}, true);
    return OpUnderTest{{ta, tb}, concat({ta, tb})};
  };
  const auto out = run_forward(build, {a, b});
  std::vector<double> ref;
  for (size_t r = 0; r < 13; ++r) {
    for (size_t c = 0; c < 3; ++c) ref.push_back(a[r * 3 + c]);
    for (size_t c = 0; c < 5; ++c) ref.push_back(b[r * 5 + c]);
  }
  expect_close(out, ref, 0, 0, "concat is an exact copy");
  check_gradients(build, {a, b});
}

BOOST_AUTO_TEST_CASE(gradient_of_a_tensor_read_twice_is_summed) {
  // concat(x, x): the second slot must add to the first slot's gradient, not overwrite it.
  check_gradients(
      [](Graph& g) {
        Tensor x = g.input("x", Shape{7, 4}, true);
        return OpUnderTest{{x}, concat({x, x})};
      },
      {random_floats(28, -1, 1, 61)});
}

BOOST_AUTO_TEST_CASE(mse_forward_and_gradient) {
  const size_t n = 3001;  // several reduction parts, the last one partial
  const auto p = random_floats(n, -2, 2, 71), t = random_floats(n, -2, 2, 72);
  const auto build = [&](Graph& g) {
    Tensor tp = g.input("pred", Shape{n}, true), tt = g.input("target", Shape{n}, true);
    return OpUnderTest{{tp, tt}, mse(tp, tt)};
  };
  const auto out = run_forward(build, {p, t});
  double ref = 0;
  for (size_t i = 0; i < n; ++i) ref += (static_cast<double>(p[i]) - t[i]) * (p[i] - t[i]);
  // A float32 sum of n = 3001 terms in two stages (<= ~50 terms each stage-1 chain, then
  // 64): relative error well under 1e-5.
  expect_close(out, {ref / n}, 0, 1e-5, "mse");
  test::GradCheckOptions o;
  o.max_components = 24;
  check_gradients(build, {p, t}, o);
}

BOOST_AUTO_TEST_CASE(weighted_sum_forward_and_gradient) {
  const auto a = random_floats(10, -1, 1, 81), b = random_floats(10, -1, 1, 82);
  const auto build = [](Graph& g) {
    Tensor ta = g.input("a", Shape{10}, true), tb = g.input("b", Shape{10}, true);
    Tensor zero = g.input("zero", Shape{10});
    return OpUnderTest{{ta, tb, zero},
                       weighted_sum({mse(ta, zero), mse(tb, zero)}, {3.0f, 0.5f})};
  };
  const std::vector<float> zeros(10, 0.0f);
  const auto out = run_forward(build, {a, b, zeros});
  double sa = 0, sb = 0;
  for (size_t i = 0; i < 10; ++i) {
    sa += static_cast<double>(a[i]) * a[i];
    sb += static_cast<double>(b[i]) * b[i];
  }
  expect_close(out, {3.0 * sa / 10 + 0.5 * sb / 10}, 0, 1e-6, "weighted sum");
  check_gradients(build, {a, b, zeros});
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

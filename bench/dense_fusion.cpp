// Fused dense layers against linear + bias_act: one hidden layer alone (nova-bench mlp's
// "dense layer" table); bench_mlp.cpp times the whole network both ways.
#include "dense_fusion.hpp"

#include <algorithm>
#include <chrono>
#include <memory>
#include <vector>

#include "bench.hpp"
#include "nova/graph/executor.hpp"
#include "nova/ops/linalg/gemm.hpp"
#include "nova/ops/linalg/dense.hpp"
#include "nova/loss/terms.hpp"

namespace nova::bench {
namespace {

double seconds(const std::function<void()>& fn) {
  const auto t0 = std::chrono::steady_clock::now();
  fn();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// A w -> w ReLU layer on [m, w] inputs, fused or as two ops, with an mse loss for backward.
struct LayerGraph {
  Graph g;
  std::unique_ptr<Executor> ex;
  LayerGraph(Runtime& rt, size_t m, size_t w, bool fused, bool backward) {
    Tensor x = g.input("x", Shape{m, w}, backward);
    Tensor wt = g.parameter("w", Shape{w, w}, Init::uniform(1.0f / 16));
    Tensor b = g.parameter("b", Shape{w}, Init::uniform(1.0f / 16));
    Tensor y = fused ? dense(x, wt, b, Activation::ReLU)
                     : bias_act(linear(x, wt), b, Activation::ReLU);
    Tensor target = g.input("target", y.shape());
    if (backward)
      g.set_loss(mse(y, target));
    else
      g.keep(y);
    ex = std::make_unique<Executor>(rt, g);
    ex->set(x, std::vector<float>(m * w, 0.5f));
    ex->set(target, std::vector<float>(m * w, 0.25f));
  }
  void run(Runtime& rt, bool backward) {
    ex->forward();
    if (backward) ex->backward();
    rt.finish();
  }
};

}  // namespace

FusedTimes time_alternating(int repeats, const std::function<void()>& fused,
                            const std::function<void()>& two_ops) {
  fused();
  two_ops();
  std::vector<double> a, b;
  for (int r = 0; r < repeats; ++r) {
    a.push_back(seconds(fused));
    b.push_back(seconds(two_ops));
  }
  return {median(a), median(b)};
}

DenseLayerTimes time_dense_layer(Runtime& rt, size_t m, size_t w, int repeats) {
  DenseLayerTimes t;
  for (bool backward : {false, true}) {
    LayerGraph fused(rt, m, w, true, backward), two(rt, m, w, false, backward);
    (backward ? t.step : t.forward) = time_alternating(
        repeats, [&] { fused.run(rt, backward); }, [&] { two.run(rt, backward); });
  }
  const GemmArgs forward{false, false, m, w, w, 1.0f, nullptr, w, m * w, nullptr, w, w * w,
                         0.0f, nullptr, w, m * w, 1};
  const GemmConfig cfg = gemm_choice(rt, forward);
  t.config = cfg.str() + (gemm_fuses_epilogue(cfg, forward, Activation::ReLU) ? " (fused)" : " (+ bias_act pass)");
  return t;
}

}  // namespace nova::bench

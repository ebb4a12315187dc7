// The executor: memory planning from lifetimes, inference-only graphs, profiling.
#include <boost/test/unit_test.hpp>
#include <random>

#include "harness.hpp"
#include "nova/graph/executor.hpp"
#include "nova/model/mlp.hpp"
#include "nova/ops/encoding/positional_encoding.hpp"
#include "nova/loss/terms.hpp"
#include "nova/tuning/tuning.hpp"

using namespace nova;

namespace {

// An op that treats its input as a constant (Op::differentiable_in), writes zeros and counts
// its backwards.
class ConstantZeroOp final : public Op {
 public:
  explicit ConstantZeroOp(int& backwards) : backwards_(backwards) {}
  std::string type() const override { return "constant_zero"; }
  bool differentiable_in(size_t) const override { return false; }
  void forward(ExecContext& ctx) override { ctx.rt.fill_zero(ctx.out(0), 4 * sizeof(float)); }
  void backward(ExecContext&) override { ++backwards_; }

 private:
  int& backwards_;
};

// A small encoded MLP with an MSE loss: x [rows, 3] -> positional encoding -> MLP -> y [rows, 4].
struct SmallMlp {
  Tensor x, target, y;
};
SmallMlp small_mlp(Graph& g, size_t rows, int freqs, int depth, int width, int skip) {
  Tensor x = g.input("x", Shape{rows, 3});
  Tensor target = g.input("target", Shape{rows, 4});
  MlpConfig c;
  c.depth = depth;
  c.width = width;
  c.skip = skip;
  Tensor y = build_mlp(positional_encoding(x, freqs), c).output;
  g.set_loss(mse(y, target));
  return {x, target, y};
}

}  // namespace

BOOST_AUTO_TEST_SUITE(executor)

// An output that takes no gradient from its only differentiable input needs none, and its op
// runs no backward, though it feeds the loss and the input takes a gradient elsewhere.
BOOST_AUTO_TEST_CASE(an_input_treated_as_constant_starts_no_backward) {
  Graph g;
  Tensor x = g.input("x", Shape{4}, true), t = g.input("t", Shape{4});
  Tensor c = g.activation("c", Shape{4});
  int backwards = 0;
  g.add(std::make_unique<ConstantZeroOp>(backwards), {x}, {c});
  BOOST_TEST(!c.info().requires_grad);
  g.set_loss(weighted_sum({mse(x, t), mse(c, t)}, {1.0f, 1.0f}));
  Executor ex(test::runtime(), g);
  const std::vector<float> xv = {1, 2, 3, 4}, tv = {0, 0, 0, 0};
  ex.set(x, xv);
  ex.set(t, tv);
  ex.forward();
  ex.backward();
  BOOST_TEST(backwards == 0);
  // d/dx of mse(x, t) alone: 2 (x - t) / 4.
  const std::vector<float> dx = ex.get_grad(x);
  for (size_t i = 0; i < 4; ++i) BOOST_TEST(dx[i] == 0.5f * xv[i], boost::test_tools::tolerance(1e-6f));
}

// An input never set would be read as what its arena held before (another run's tensors);
// forward() refuses it and names it.
BOOST_AUTO_TEST_CASE(an_input_never_set_is_refused) {
  Graph g;
  const SmallMlp m = small_mlp(g, 8, 2, 1, 8, -1);
  Executor ex(test::runtime(), g);
  ex.set(m.x, std::vector<float>(8 * 3, 0.5f));
  try {
    ex.forward();
    BOOST_FAIL("forward() ran with the input 'target' never set");
  } catch (const Error& e) {
    BOOST_TEST(std::string(e.what()).find("'target' was never set") != std::string::npos, e.what());
  }
  ex.set(m.target, std::vector<float>(8 * 4, 0.0f));
  BOOST_CHECK_NO_THROW(ex.forward());
}

BOOST_AUTO_TEST_CASE(plan_never_overlaps_live_tensors) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<Lifetime> t(40);
    for (auto& l : t) {
      l.bytes = 1 + rng() % 5000;
      l.first = static_cast<int>(rng() % 30);
      l.last = l.first + static_cast<int>(rng() % 10);
    }
    const MemoryPlan p = plan_memory(t, 64);
    size_t peak = 0;
    for (size_t i = 0; i < t.size(); ++i) {
      BOOST_TEST(p.offsets[i] % 64 == 0u);
      peak = std::max(peak, p.offsets[i] + t[i].bytes);
      for (size_t j = 0; j < i; ++j) {
        const bool live_together = t[i].first <= t[j].last && t[j].first <= t[i].last;
        const bool overlap = p.offsets[i] < p.offsets[j] + t[j].bytes &&
                             p.offsets[j] < p.offsets[i] + t[i].bytes;
        BOOST_TEST(!(live_together && overlap), "tensors " << i << " and " << j);
      }
    }
    BOOST_TEST(peak <= p.peak_bytes);
    BOOST_TEST(p.peak_bytes <= p.total_bytes);
  }
}

BOOST_AUTO_TEST_CASE(plan_reuses_memory_of_a_chain) {
  // A chain where each tensor dies when the next is made needs two buffers, not ten.
  std::vector<Lifetime> t;
  for (int i = 0; i < 10; ++i) t.push_back({1024, i, i + 1});
  const MemoryPlan p = plan_memory(t, 256);
  BOOST_TEST(p.peak_bytes == 2048u);
  BOOST_TEST(p.total_bytes == 10240u);
}

BOOST_AUTO_TEST_CASE(reference_mlp_plan_needs_less_than_all_tensors) {
  Graph g;
  Tensor x = g.input("x", Shape{512, 63});
  Tensor target = g.input("target", Shape{512, 4});
  g.set_loss(mse(build_mlp(x, MlpConfig{}).output, target));
  Executor ex(test::runtime(), g);
  BOOST_TEST_MESSAGE("reference MLP, 512 rows: planned " << ex.plan().peak_bytes << " B, "
                     << "one buffer per tensor " << ex.plan().total_bytes << " B");
  BOOST_TEST(ex.plan().peak_bytes < ex.plan().total_bytes);
  // 63 -> 256, four 256 -> 256, the skip layer (256 + 63) -> 256, two 256 -> 256, 256 -> 4.
  const size_t expected = (63 * 256 + 256) + 4 * (256 * 256 + 256) + (319 * 256 + 256) +
                          2 * (256 * 256 + 256) + (256 * 4 + 4);
  BOOST_TEST(ex.parameter_count() == expected);
}

// The two arena layouts (nova/tuning/tuning.hpp) run the same ops on the same values: loss, output
// and every parameter gradient agree bit for bit; the planned arena reuses memory (its
// sub-buffers overlap), the separate one gives each tensor a buffer of its own.
BOOST_AUTO_TEST_CASE(separate_buffers_give_the_arenas_bits) {
  const auto run = [](const char* layout) {
    setenv("NOVA_ARENA", layout, 1);
    Graph g;
    const auto [x, target, y] = small_mlp(g, 301, 3, 4, 32, 1);
    g.keep(y);
    Executor ex(test::runtime(), g);
    unsetenv("NOVA_ARENA");
    // The comparison means something only where the planned arena reuses memory.
    BOOST_TEST(ex.plan().peak_bytes < ex.plan().total_bytes);
    ex.set(x, test::random_floats(301 * 3, -1, 1, 5));
    ex.set(target, test::random_floats(301 * 4, 0, 1, 6));
    ex.forward();
    ex.backward();
    std::vector<std::vector<float>> out{ex.get(y), ex.get(g.loss())};
    for (Tensor w : g.parameters()) out.push_back(ex.get_grad(w));
    return out;
  };
  const auto arena = run("sub-buffers"), separate = run("separate");
  BOOST_TEST(arena.size() == separate.size());
  for (size_t i = 0; i < arena.size() && i < separate.size(); ++i)
    BOOST_TEST(arena[i] == separate[i], boost::test_tools::per_element());
  setenv("NOVA_ARENA", "shared", 1);
  BOOST_CHECK_THROW(arena_layout(test::runtime().info()), Error);
  unsetenv("NOVA_ARENA");
}

BOOST_AUTO_TEST_CASE(inference_graph_frees_activations_early) {
  const auto plan_bytes = [](bool with_loss) {
    Graph g;
    Tensor x = g.input("x", Shape{256, 63});
    Tensor target = g.input("target", Shape{256, 4});
    Tensor y = build_mlp(x, MlpConfig{}).output;
    if (with_loss) g.set_loss(mse(y, target));
    else g.keep(y);
    Executor ex(test::runtime(), g);
    return ex.plan().peak_bytes;
  };
  // Without a backward pass no activation waits for it: at 256 rows the GEMM scratch
  // dominates what is left, and the inference arena is under half the training one.
  BOOST_TEST(plan_bytes(false) * 2 < plan_bytes(true));
}

BOOST_AUTO_TEST_CASE(profile_table_names_every_op) {
  Graph g;
  const auto [x, target, y] = small_mlp(g, 64, 2, 2, 16, 0);
  ExecutorOptions o;
  o.profile = true;
  Executor ex(test::runtime(), g, o);
  ex.set(x, test::random_floats(64 * 3, -1, 1, 1));
  ex.set(target, test::random_floats(64 * 4, 0, 1, 2));
  ex.forward();
  ex.backward();
  const auto t = ex.timings();
  const std::string table = ex.profile_table();
  for (const char* op : {"dense_relu", "dense_identity", "concat", "positional_encoding", "mse",
                         "dense_relu (backward)", "dense_identity (backward)"})
    BOOST_TEST(table.find(op) != std::string::npos, op << " missing from\n" << table);
  for (const auto& row : t) BOOST_TEST(row.ms >= 0.0);
}

BOOST_AUTO_TEST_SUITE_END()

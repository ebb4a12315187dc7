// The novel-view losses as a whole (each op alone is an entry of the op table,
// tests/op_table_losses.cpp): the weighted builder against the sum of its terms, a weight of 0
// leaving its term out of the graph, the static NeRF left out of alpha_loss.
#include <boost/test/unit_test.hpp>
#include <cmath>
#include <set>

#include "harness.hpp"
#include "loss_reference.hpp"
#include "nova/loss/terms.hpp"
#include "nova/loss/objective.hpp"
#include "nova/render/render_composite.hpp"

using namespace nova;
using namespace nova::test;

namespace {

// Losses are single float32 sums of at most a few thousand terms of size O(1): relative
// error about n * 6e-8 in the worst case, 1e-6 in practice with the two-stage sum; rtol 1e-5
// with atol 1e-7 is tight enough to catch a wrong normalisation or a missed term.
constexpr double kAtol = 1e-7, kRtol = 1e-5;

}  // namespace

BOOST_AUTO_TEST_SUITE(losses)

// alpha_loss's static NeRF is exempt: its rows get an exactly zero gradient. (Each loss alone
// against its float64 reference and central differences: tests/op_table_losses.cpp.)
BOOST_AUTO_TEST_CASE(alpha_loss_leaves_the_static_nerf_alone) {
  const size_t N = 3, R = 6, S = 8;
  const auto raw = smooth_raw(N, R * S, 5);
  const auto delta = random_floats(R * S, 0.05f, 0.5f, 6);
  auto masks = random_floats(N * R, 0, 1, 7);
  for (float& m : masks) m = m < 0.5f ? 0.0f : 1.0f;
  Graph g2;
  Tensor r2 = g2.input("raw", Shape{N, R * S, 5}, true), d2 = g2.input("delta", Shape{R, S}),
         m2 = g2.input("masks", Shape{N, R});
  g2.set_loss(alpha_loss(r2, d2, m2));
  Executor ex(runtime(), g2);
  ex.set(r2, raw);
  ex.set(d2, delta);
  ex.set(m2, masks);
  ex.forward();
  ex.backward();
  const auto grad = ex.get_grad(r2);
  for (size_t e = 0; e < R * S * 5; ++e) BOOST_TEST(grad[e] == 0.0f);
}

namespace {

// A whole novel-view graph: raw -> render_composite -> novel_view_loss.
struct LossGraph {
  Graph g;
  Tensor raw, delta, z, rgb, masks;
  NovelViewLoss loss;
};

void build_loss_graph(LossGraph& lg, size_t N, size_t R, size_t S, const NovelViewLossWeights& w) {
  Graph& g = lg.g;
  lg.raw = g.input("raw", Shape{N, R * S, 5}, true);
  lg.delta = g.input("delta", Shape{R, S});
  lg.z = g.input("z", Shape{R, S});
  lg.rgb = g.input("target_rgb", Shape{R, 3});
  lg.masks = g.input("masks", Shape{N, R});
  const RenderOutputs out = render_composite(lg.raw, lg.delta, lg.z);
  lg.loss = novel_view_loss(out, lg.raw, lg.delta, Tensor{}, {lg.rgb, lg.masks}, w);
  g.set_loss(lg.loss.total);
}

std::multiset<std::string> op_types(const Graph& g) {
  std::multiset<std::string> s;
  for (size_t n = 0; n < g.node_count(); ++n) s.insert(g.node(n).type());
  return s;
}

}  // namespace

BOOST_AUTO_TEST_CASE(zero_weight_terms_are_not_built) {
  const size_t N = 3, R = 4, S = 8;
  LossGraph all;
  build_loss_graph(all, N, R, S, {});
  // render + mse (full rgb) + masked_mse + mse (mask) + blending + alpha + weighted_sum.
  BOOST_TEST(all.g.node_count() == 7u);
  const std::pair<float NovelViewLossWeights::*, std::string> terms[] = {
      {&NovelViewLossWeights::full_rgb, "mse"},
      {&NovelViewLossWeights::nerf_rgb, "masked_mse"},
      {&NovelViewLossWeights::mask, "mse"},
      {&NovelViewLossWeights::blending, "blending_loss"},
      {&NovelViewLossWeights::alpha, "alpha_loss"}};
  for (const auto& [field, type] : terms) {
    NovelViewLossWeights w;
    w.*field = 0.0f;
    LossGraph lg;
    build_loss_graph(lg, N, R, S, w);
    BOOST_TEST(lg.g.node_count() == 6u, "weight of " << type << " set to 0");
    const auto a = op_types(all.g), b = op_types(lg.g);
    BOOST_TEST(a.count(type) == b.count(type) + 1, type << " still built with weight 0");
  }
  // Without object NeRFs the alpha loss has nothing to act on and is never built.
  LossGraph single;
  build_loss_graph(single, 1, R, S, {});
  BOOST_TEST(op_types(single.g).count("alpha_loss") == 0u);
  BOOST_TEST(!single.loss.alpha.valid());
  // Every weight 0 is a configuration error, not an empty loss.
  NovelViewLossWeights none{0, 0, 0, 0, 0};
  LossGraph empty;
  BOOST_CHECK_THROW(build_loss_graph(empty, N, R, S, none), Error);
}

BOOST_AUTO_TEST_CASE(weighted_total_and_gradient) {
  const size_t N = 2, R = 4, S = 8;
  NovelViewLossWeights w;  // the reference weights 3, 1, 0.1, 0.1, 0.1
  LossGraph lg;
  build_loss_graph(lg, N, R, S, w);
  const NovelViewLoss& l = lg.loss;
  for (Tensor t : {l.full_rgb, l.nerf_rgb, l.mask, l.blending, l.alpha}) lg.g.keep(t);
  const auto raw = smooth_raw(N, R * S, 9);
  std::vector<float> delta(R * S, 1.0f / S), z(R * S);
  for (size_t e = 0; e < R * S; ++e) z[e] = (e % S + 0.5f) / S;
  const auto rgb = random_floats(R * 3, 0, 1, 10);
  auto masks = random_floats(N * R, 0, 1, 11);
  for (float& m : masks) m = m < 0.5f ? 0.0f : 1.0f;
  Executor ex(runtime(), lg.g);
  ex.set(lg.raw, raw);
  ex.set(lg.delta, delta);
  ex.set(lg.z, z);
  ex.set(lg.rgb, rgb);
  ex.set(lg.masks, masks);
  ex.forward();
  const double expected = 3.0 * ex.get(l.full_rgb)[0] + 1.0 * ex.get(l.nerf_rgb)[0] +
                          0.1 * ex.get(l.mask)[0] + 0.1 * ex.get(l.blending)[0] +
                          0.1 * ex.get(l.alpha)[0];
  expect_close({ex.loss()}, {expected}, kAtol, kRtol, "weighted total");
  // The terms that need only raw are checked against their float64 references too.
  expect_close(ex.get(l.blending), {ref_blending(raw, N, R * S)}, kAtol, kRtol, "blending term");
  expect_close(ex.get(l.alpha), {ref_alpha(raw, delta, masks, N, R, S)}, kAtol, kRtol, "alpha term");

  // The whole chain render -> losses, by float32 central differences of the device forward
  // (harness default tolerance).
  check_gradients(
      [&](Graph& g) {
        Tensor r = g.input("raw", Shape{N, R * S, 5}, true), d = g.input("delta", Shape{R, S}),
               zz = g.input("z", Shape{R, S}), t = g.input("target_rgb", Shape{R, 3}),
               m = g.input("masks", Shape{N, R});
        const RenderOutputs out = render_composite(r, d, zz);
        return OpUnderTest{{r, d, zz, t, m}, novel_view_loss(out, r, d, Tensor{}, {t, m}, w).total};
      },
      {raw, delta, z, rgb, masks});
}

BOOST_AUTO_TEST_CASE(pretrain_rgb_loss_is_plain_or_background_mse) {
  const size_t R = 30;
  const auto pred = random_floats(R * 3, 0, 1, 12), target = random_floats(R * 3, 0, 1, 13);
  auto bg = random_floats(R, 0, 1, 14);
  for (float& b : bg) b = b < 0.3f ? 0.0f : 1.0f;
  Graph g;
  Tensor p = g.input("rgb", Shape{R, 3}), t = g.input("target", Shape{R, 3}), b = g.input("bg", Shape{R});
  Tensor plain = pretrain_rgb_loss(p, t), masked = pretrain_rgb_loss(p, t, b);
  g.keep(plain);
  g.keep(masked);
  Executor ex(runtime(), g);
  ex.set(p, pred);
  ex.set(t, target);
  ex.set(b, bg);
  ex.forward();
  const std::vector<float> ones(R, 1.0f);
  expect_close(ex.get(plain), {ref_masked_mse(pred, target, ones, 1, R, 3)}, kAtol, kRtol, "plain");
  expect_close(ex.get(masked), {ref_masked_mse(pred, target, bg, 1, R, 3)}, kAtol, kRtol, "background");
}

BOOST_AUTO_TEST_SUITE_END()

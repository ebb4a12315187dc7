// The op table's losses of rendered values: mse and weighted_sum; the novel-view terms alone
// (masked_mse, blending_loss, alpha_loss) and together (with mse, summed by weighted_sum); the
// reference code's terms (mask_l1_loss, masked_mse_area, alpha_loss_outside, order_loss); over
// 1009 rays (several work-groups, a partial last one) and small cases. The losses along rays
// and depths are in op_table_ray_losses.cpp.
#include <cmath>

#include "conventions_reference.hpp"
#include "loss_reference.hpp"
#include "nova/loss/terms.hpp"
#include "op_table.hpp"
#include "loss/group_ratio.hpp"

namespace nova::test {

namespace {

constexpr float kW[4] = {0.7f, 1.3f, 0.4f, 2.1f};  // weights of the four terms summed

// Float32 two-stage sums of a few thousand O(1) terms: rtol 1e-5, atol 1e-7 (test_losses).
constexpr Tolerance kLossSum{1e-7, 1e-5};

OpEntry mse_entry() {
  OpEntry e;
  e.name = "mse";
  // 3001: several reduction parts, the last one partial; both inputs differentiated.
  OpShape big{{3001}, 0, "3001"};
  big.fd = GradCheckOptions{};
  big.fd->max_components = 24;
  e.shapes = {big, {{1}, 0, "1"}, {{37}, 0, "37"}};
  e.build = [](Graph& g, const OpShape& s) {
    Tensor p = g.input("pred", Shape{s.dims[0]}, true), t = g.input("target", Shape{s.dims[0]}, true);
    Tensor l = mse(p, t);
    return OpGraph{{p, t}, {l}, l};
  };
  e.values = [](const OpShape& s) {
    return std::vector<std::vector<float>>{random_floats(s.dims[0], -2, 2, 71), random_floats(s.dims[0], -2, 2, 72)};
  };
  e.reference = [](const OpCase& c) {
    double ref = 0;
    for (size_t i = 0; i < c.values[0].size(); ++i) ref += (double(c.values[0][i]) - c.values[1][i]) * (double(c.values[0][i]) - c.values[1][i]);
    // A float32 sum of n terms in two stages (<= ~50 terms each stage-1 chain, then 64):
    // relative error well under 1e-5.
    return std::vector<Expected>{{{ref / double(c.values[0].size())}, {0, 1e-5}}};
  };
  e.gradient = [](const OpCase& c) {
    std::vector<double> dp(c.values[0].size()), dt(dp.size());
    for (size_t i = 0; i < dp.size(); ++i) dt[i] = -(dp[i] = 2.0 * (double(c.values[0][i]) - c.values[1][i]) / double(dp.size()));
    return std::vector<Expected>{grad_expected(dp), grad_expected(dt)};
  };
  e.fd = GradCheckOptions{};
  e.flops = [](const OpShape& s) { return double(s.dims[0]) * 6; };
  return e;
}

OpEntry weighted_sum_entry() {
  OpEntry e;
  e.name = "weighted_sum";
  // sum_i w_i mse(a_i, 0) over n values and T terms; dims {n, T}. Two terms with weights 3 and
  // 0.5; eleven (two launches of eight) with weights 0.25 + 0.5 i, every third term's input
  // without a gradient.
  e.shapes = {{{10, 2}, 0, "2 x 10"}, {{1, 2}, 0, "2 x 1"}, {{3, 11}, 0, "11 x 3, every third without a gradient"}};
  const auto weight = [](size_t T, size_t i) { return T == 2 ? (i == 0 ? 3.0f : 0.5f) : 0.25f + 0.5f * static_cast<float>(i); };
  const auto wants_grad = [](size_t T, size_t i) { return T == 2 || i % 3 != 2; };
  e.build = [=](Graph& g, const OpShape& s) {
    const size_t n = s.dims[0], T = s.dims[1];
    std::vector<Tensor> inputs, terms;
    std::vector<float> w;
    Tensor zero = g.input("zero", Shape{n});
    for (size_t i = 0; i < T; ++i) {
      inputs.push_back(g.input("a" + std::to_string(i), Shape{n}, wants_grad(T, i)));
      terms.push_back(mse(inputs.back(), zero));
      w.push_back(weight(T, i));
    }
    inputs.push_back(zero);
    Tensor l = weighted_sum(terms, w);
    return OpGraph{inputs, {l}, l};
  };
  e.values = [](const OpShape& s) {
    std::vector<std::vector<float>> v;
    for (size_t i = 0; i < s.dims[1]; ++i) v.push_back(random_floats(s.dims[0], -1, 1, 81 + static_cast<uint32_t>(i)));
    v.push_back(std::vector<float>(s.dims[0], 0.0f));
    return v;
  };
  e.reference = [=](const OpCase& c) {
    const size_t T = c.shape.dims[1];
    const double n = double(c.shape.dims[0]);
    double total = 0;
    for (size_t i = 0; i < T; ++i) {
      double sq = 0;
      for (float x : c.values[i]) sq += double(x) * x;
      total += double(weight(T, i)) * sq / n;
    }
    // float32 sums of <= 10 squares and a weighted sum of <= 11 positive terms: rtol 1e-6.
    return std::vector<Expected>{{{total}, {0, 1e-6}}};
  };
  e.gradient = [=](const OpCase& c) {
    const size_t T = c.shape.dims[1];
    const double n = double(c.shape.dims[0]);
    std::vector<Expected> out;
    for (size_t i = 0; i < T; ++i) {
      if (!wants_grad(T, i)) {
        out.push_back({});
        continue;
      }
      std::vector<double> d;
      for (float x : c.values[i]) d.push_back(double(weight(T, i)) * 2.0 * x / n);
      out.push_back(grad_expected(d));
    }
    out.push_back({});
    return out;
  };
  e.fd = GradCheckOptions{};
  e.flops = [](const OpShape& s) { return double(s.dims[0] * s.dims[1]) * 6; };
  return e;
}

// One novel-view term alone, as its own op: forward against the float64 reference at
// kLossSum, gradients by central differences at the harness default (the losses are smooth
// in raw and quadratic in pred). dims: NeRFs or groups, rays, channels or samples.
OpEntry masked_mse_entry() {
  OpEntry e;
  e.name = "masked_mse";
  e.shapes = {{{3, 50, 3}, 0, "3 x 50 x 3"}, {{1, 1, 3}, 0, "1 x 1 x 3"}};
  e.build = [](Graph& g, const OpShape& s) {
    const size_t G = s.dims[0], R = s.dims[1], K = s.dims[2];
    Tensor p = g.input("pred", Shape{G, R, K}, true), t = g.input("target", Shape{R, K}), m = g.input("mask", Shape{G, R});
    Tensor l = masked_mse(p, t, m);
    return OpGraph{{p, t, m}, {l}, l};
  };
  e.values = [](const OpShape& s) {
    const size_t G = s.dims[0], R = s.dims[1], K = s.dims[2];
    auto mask = random_floats(G * R, 0, 1, 3);
    for (float& m : mask) m = m < 0.4f ? 0.0f : m < 0.8f ? 1.0f : m;  // binary and soft
    return std::vector<std::vector<float>>{random_floats(G * R * K, 0, 1, 1), random_floats(R * K, 0, 1, 2), mask};
  };
  e.reference = [](const OpCase& c) {
    const auto& v = c.values;
    return std::vector<Expected>{{{ref_masked_mse(v[0], v[1], v[2], c.shape.dims[0], c.shape.dims[1], c.shape.dims[2])}, kLossSum}};
  };
  e.fd = GradCheckOptions{};
  e.flops = [](const OpShape& s) { return double(s.dims[0] * s.dims[1] * s.dims[2]) * 6; };
  return e;
}

OpEntry blending_loss_entry() {
  OpEntry e;
  e.name = "blending_loss";
  e.shapes = {{{3, 40}, 0, "3 x 40"}, {{2, 1}, 0, "2 x 1"}};
  e.build = [](Graph& g, const OpShape& s) {
    Tensor r = g.input("raw", Shape{s.dims[0], s.dims[1], 5}, true);
    Tensor l = blending_loss(r);
    return OpGraph{{r}, {l}, l};
  };
  e.values = [](const OpShape& s) {
    const size_t N = s.dims[0], M = s.dims[1];
    auto raw = smooth_raw(N, M, 4);
    // Some samples with the sum below 1 (blend raw -3: sigmoid 0.047 each, sum 0.14) to cover
    // both signs of |sum - 1|.
    for (size_t m = 0; m < M; m += 4)
      for (size_t n = 0; n < N; ++n) raw[(n * M + m) * 5 + 4] = -3.0f;
    return std::vector<std::vector<float>>{raw};
  };
  e.reference = [](const OpCase& c) {
    return std::vector<Expected>{{{ref_blending(c.values[0], c.shape.dims[0], c.shape.dims[1])}, kLossSum}};
  };
  e.fd = GradCheckOptions{};
  e.flops = [](const OpShape& s) { return double(s.dims[0] * s.dims[1]) * 20; };
  return e;
}

OpEntry alpha_loss_entry() {
  OpEntry e;
  e.name = "alpha_loss";
  e.shapes = {{{3, 6, 8}, 0, "3 x 6 x 8"}, {{2, 1, 1}, 0, "2 x 1 x 1"}};
  e.build = [](Graph& g, const OpShape& s) {
    const size_t N = s.dims[0], R = s.dims[1], S = s.dims[2];
    Tensor r = g.input("raw", Shape{N, R * S, 5}, true), d = g.input("delta", Shape{R, S}), m = g.input("masks", Shape{N, R});
    Tensor l = alpha_loss(r, d, m);
    return OpGraph{{r, d, m}, {l}, l};
  };
  e.values = [](const OpShape& s) {
    const size_t N = s.dims[0], R = s.dims[1], S = s.dims[2];
    auto masks = random_floats(N * R, 0, 1, 7);
    for (float& m : masks) m = m < 0.5f ? 0.0f : 1.0f;
    return std::vector<std::vector<float>>{smooth_raw(N, R * S, 5), random_floats(R * S, 0.05f, 0.5f, 6), masks};
  };
  e.reference = [](const OpCase& c) {
    const auto& v = c.values;
    return std::vector<Expected>{{{ref_alpha(v[0], v[1], v[2], c.shape.dims[0], c.shape.dims[1], c.shape.dims[2])}, kLossSum}};
  };
  e.fd = GradCheckOptions{};
  e.flops = [](const OpShape& s) { return double(s.dims[0] * s.dims[1] * s.dims[2]) * 20; };
  return e;
}

OpEntry novel_view_losses_entry() {
  OpEntry e;
  e.name = "novel_view_losses";
  // dims: rays M, groups G = NeRFs N, channels K = samples S.
  e.shapes = {{{kOddRows, 3, 3}, 0, "1009 rays, 3 NeRFs x 3"}, {{1, 2, 1}, 0, "1 ray, 2 NeRFs x 1"}};
  e.build = [](Graph& g, const OpShape& s) {
    const size_t M = s.dims[0], G = s.dims[1], K = s.dims[2], N = G, S = K;
    Tensor tp = g.input("pred", Shape{G, M, K}, true), tt = g.input("target", Shape{M, K}),
           tm = g.input("mask", Shape{G, M});
    Tensor tb = g.input("blend_raw", Shape{N, M, 5}, true);
    Tensor ta = g.input("alpha_raw", Shape{N, M * S, 5}, true), td = g.input("delta", Shape{M, S}),
           tms = g.input("masks", Shape{N, M});
    Tensor tp2 = g.input("p2", Shape{M, 7}, true), tt2 = g.input("t2", Shape{M, 7}, true);
    std::vector<Tensor> terms = {masked_mse(tp, tt, tm), blending_loss(tb), alpha_loss(ta, td, tms), mse(tp2, tt2)};
    Tensor total = weighted_sum(terms, {kW[0], kW[1], kW[2], kW[3]});
    terms.push_back(total);
    return OpGraph{{tp, tt, tm, tb, ta, td, tms, tp2, tt2}, terms, total};
  };
  e.values = [](const OpShape& s) {
    const size_t M = s.dims[0], G = s.dims[1], K = s.dims[2], N = G, S = K;
    auto mask = random_floats(G * M, 0, 1, 133);
    for (float& m : mask) m = m < 0.4f ? 0.0f : m < 0.8f ? 1.0f : m;  // binary and soft
    auto masks = random_floats(N * M, 0, 1, 137);
    for (float& m : masks) m = m < 0.5f ? 0.0f : 1.0f;
    return std::vector<std::vector<float>>{random_floats(G * M * K, 0, 1, 131), random_floats(M * K, 0, 1, 132), mask,
                                           smooth_raw(N, M, 134), smooth_raw(N, M * S, 135),
                                           random_floats(M * S, 0.05f, 0.5f, 136), masks,
                                           random_floats(M * 7, -2, 2, 138), random_floats(M * 7, -2, 2, 139)};
  };
  e.reference = [](const OpCase& c) {
    const size_t M = c.shape.dims[0], G = c.shape.dims[1], K = c.shape.dims[2], N = G, S = K;
    const auto& v = c.values;
    double m = 0;
    for (size_t i = 0; i < v[7].size(); ++i) m += (double(v[7][i]) - v[8][i]) * (double(v[7][i]) - v[8][i]);
    const double ref[4] = {ref_masked_mse(v[0], v[1], v[2], G, M, K), ref_blending(v[3], N, M),
                           ref_alpha(v[4], v[5], v[6], N, M, S), m / double(v[7].size())};
    std::vector<Expected> out;
    double total = 0;
    for (int k = 0; k < 4; ++k) out.push_back({{ref[k]}, kLossSum}), total += kW[k] * ref[k];
    out.push_back({{total}, kLossSum});
    return out;
  };
  e.gradient = [](const OpCase& c) {
    const size_t M = c.shape.dims[0], G = c.shape.dims[1], K = c.shape.dims[2], N = G, S = K;
    const auto &pred = c.values[0], &target = c.values[1], &mask = c.values[2], &braw = c.values[3],
               &araw = c.values[4], &delta = c.values[5], &masks = c.values[6], &p2 = c.values[7], &t2 = c.values[8];
    // d/dpred: 2 mask (pred - target) / (G M K).
    std::vector<double> dpred(pred.size());
    for (size_t gi = 0; gi < G; ++gi)
      for (size_t r = 0; r < M; ++r)
        for (size_t k = 0; k < K; ++k) {
          const size_t i = (gi * M + r) * K + k;
          dpred[i] = kW[0] * 2.0 * mask[gi * M + r] * (double(pred[i]) - target[r * K + k]) / double(G * M * K);
        }
    // d/draw blend channel: sign(sum_n sigmoid(b) - 1) sigmoid'(b) / M; other channels 0.
    std::vector<double> dblend(braw.size(), 0.0);
    for (size_t m = 0; m < M; ++m) {
      double sum = 0;
      for (size_t n = 0; n < N; ++n) sum += loss_sigmoid(braw[(n * M + m) * 5 + 4]);
      for (size_t n = 0; n < N; ++n) {
        const double s = loss_sigmoid(braw[(n * M + m) * 5 + 4]);
        dblend[(n * M + m) * 5 + 4] = kW[1] * (sum > 1 ? 1.0 : -1.0) * s * (1 - s) / double(M);
      }
    }
    // Object NeRFs n >= 1 outside their mask: d alpha / d sigma = delta exp(-sigma delta) where
    // sigma > 0, and sigmoid' for the blend; the static NeRF's rows are 0.
    std::vector<double> dalpha(araw.size(), 0.0);
    const double denom = double((N - 1) * M * S);
    for (size_t n = 1; n < N; ++n)
      for (size_t r = 0; r < M; ++r)
        for (size_t i = 0; i < S; ++i) {
          const size_t at = (n * M + r) * S + i;
          const double out = 1.0 - masks[n * M + r], d = delta[r * S + i];
          const double sigma = araw[at * 5 + 3], s = loss_sigmoid(araw[at * 5 + 4]);
          dalpha[at * 5 + 3] = sigma > 0 ? kW[2] * out * d * std::exp(-sigma * d) / denom : 0.0;
          dalpha[at * 5 + 4] = kW[2] * out * s * (1 - s) / denom;
        }
    std::vector<double> dp2(p2.size()), dt2(p2.size());
    for (size_t i = 0; i < p2.size(); ++i) {
      dp2[i] = kW[3] * 2.0 * (double(p2[i]) - t2[i]) / double(p2.size());
      dt2[i] = -dp2[i];
    }
    return std::vector<Expected>{grad_expected(dpred), {}, {}, grad_expected(dblend), grad_expected(dalpha), {}, {},
                                 grad_expected(dp2), grad_expected(dt2)};
  };
  e.flops = [](const OpShape& s) { return double(s.dims[0] * s.dims[1] * s.dims[2]) * 60; };
  return e;
}

OpEntry reference_losses_entry() {
  OpEntry e;
  e.name = "reference_losses";
  // dims: rays R, NeRFs N, channels K = samples S.
  e.shapes = {{{kOddRows, 3, 3}, 0, "1009 rays, 3 NeRFs x 3"}, {{1, 2, 1}, 0, "1 ray, 2 NeRFs x 1"}};
  e.build = [](Graph& g, const OpShape& s) {
    const size_t R = s.dims[0], N = s.dims[1], K = s.dims[2], S = K;
    Tensor tmp = g.input("mpred", Shape{N, R}, true), tmt = g.input("mtarget", Shape{N, R});
    Tensor tp = g.input("pred", Shape{N, R, K}, true), tt = g.input("target", Shape{N, R, K}),
           tm = g.input("mask", Shape{N, R});
    Tensor ta = g.input("alpha_raw", Shape{N, R * S, 5}, true), td = g.input("delta", Shape{R, S});
    Tensor tdp = g.input("depth", Shape{N, R}, true);
    std::vector<Tensor> terms = {mask_l1_loss(tmp, tmt), masked_mse_area(tp, tt, tm), alpha_loss_outside(ta, td, tm),
                                 order_loss(tdp, tm)};
    Tensor total = weighted_sum(terms, {kW[0], kW[1], kW[2], kW[3]});
    return OpGraph{{tmp, tmt, tp, tt, tm, ta, td, tdp}, terms, total};
  };
  e.values = [](const OpShape& s) {
    const size_t R = s.dims[0], N = s.dims[1], K = s.dims[2], S = K;
    auto mask = random_floats(N * R, 0, 1, 195);
    for (float& m : mask) m = m < 0.4f ? 0.0f : m < 0.8f ? 1.0f : m;
    return std::vector<std::vector<float>>{random_floats(N * R, 0, 1, 192), random_floats(N * R, 0, 1, 191),
                                           random_floats(N * R * K, 0, 1, 193), random_floats(N * R * K, 0, 1, 194),
                                           mask, smooth_raw(N, R * S, 196), random_floats(R * S, 0.05f, 0.5f, 197),
                                           random_floats(N * R, 0, 1, 198)};
  };
  e.reference = [](const OpCase& c) {
    const size_t R = c.shape.dims[0], N = c.shape.dims[1], K = c.shape.dims[2], S = K;
    const auto& v = c.values;
    // As the novel-view terms, with atol 1e-9: these are means of O(1e-1) values.
    const Tolerance tol{1e-9, 1e-5};
    return std::vector<Expected>{{{ref_mask_l1(v[0], v[1], N, R)}, tol},
                                 {{ref_mse_area(v[2], v[3], v[4], N, R, K)}, tol},
                                 {{ref_alpha_outside(v[5], v[6], v[4], {}, N, R, S)}, tol},
                                 {{ref_order(v[7], v[4], N, R)}, tol}};
  };
  e.gradient = [](const OpCase& c) {
    const size_t R = c.shape.dims[0], N = c.shape.dims[1], K = c.shape.dims[2], S = K;
    const auto& v = c.values;
    std::vector<double> dm(v[0].size());
    for (size_t i = 0; i < dm.size(); ++i) {
      const double d = double(v[0][i]) - v[1][i];
      dm[i] = kW[0] * (d > 0 ? 1.0 : d < 0 ? -1.0 : 0.0) / double(R);
    }
    const auto scaled = [](std::vector<double> g, float w) {
      for (double& x : g) x *= w;
      return g;
    };
    return std::vector<Expected>{grad_expected(dm), {},
                                 grad_expected(scaled(ref_mse_area_grad(v[2], v[3], v[4], N, R, K), kW[1])), {}, {},
                                 grad_expected(scaled(ref_alpha_outside_grad(v[5], v[6], v[4], N, R, S), kW[2])), {},
                                 grad_expected(scaled(ref_order_grad(v[7], v[4], N, R), kW[3]))};
  };
  e.flops = [](const OpShape& s) { return double(s.dims[0] * s.dims[1] * s.dims[2]) * 40; };
  return e;
}

// The reference code's ratio losses in the two steps of data-parallel training (ops/
// group_ratio.hpp): each loss's sums, then the loss from them, which on one rank is the loss
// itself: the same float64 references and tolerances as reference_losses. The sum over ranks
// between the steps is rank_sum's.
OpEntry reference_losses_from_sums_entry() {
  OpEntry e = reference_losses_entry();
  e.name = "reference_losses_from_sums";
  e.build = [](Graph& g, const OpShape& s) {
    const size_t R = s.dims[0], N = s.dims[1], K = s.dims[2], S = K;
    Tensor tp = g.input("pred", Shape{N, R, K}, true), tt = g.input("target", Shape{N, R, K}),
           tm = g.input("mask", Shape{N, R});
    Tensor ta = g.input("alpha_raw", Shape{N, R * S, 5}, true), td = g.input("delta", Shape{R, S});
    Tensor tdp = g.input("depth", Shape{N, R}, true);
    std::vector<Tensor> terms = {detail::group_ratio(detail::masked_mse_area_sums(tp, tt, tm)),
                                 detail::group_ratio(detail::alpha_loss_outside_sums(ta, td, tm, Tensor{}, true)),
                                 detail::group_ratio(detail::order_loss_sums(tdp, tm))};
    Tensor total = weighted_sum(terms, {kW[1], kW[2], kW[3]});
    return OpGraph{{tp, tt, tm, ta, td, tdp}, terms, total};
  };
  e.values = [](const OpShape& s) {
    const size_t R = s.dims[0], N = s.dims[1], K = s.dims[2], S = K;
    auto mask = random_floats(N * R, 0, 1, 195);
    for (float& m : mask) m = m < 0.4f ? 0.0f : m < 0.8f ? 1.0f : m;
    return std::vector<std::vector<float>>{random_floats(N * R * K, 0, 1, 193), random_floats(N * R * K, 0, 1, 194),
                                           mask, smooth_raw(N, R * S, 196), random_floats(R * S, 0.05f, 0.5f, 197),
                                           random_floats(N * R, 0, 1, 198)};
  };
  e.reference = [](const OpCase& c) {
    const size_t R = c.shape.dims[0], N = c.shape.dims[1], K = c.shape.dims[2], S = K;
    const auto& v = c.values;
    const Tolerance tol{1e-9, 1e-5};  // as reference_losses
    return std::vector<Expected>{{{ref_mse_area(v[0], v[1], v[2], N, R, K)}, tol},
                                 {{ref_alpha_outside(v[3], v[4], v[2], {}, N, R, S)}, tol},
                                 {{ref_order(v[5], v[2], N, R)}, tol}};
  };
  e.gradient = [](const OpCase& c) {
    const size_t R = c.shape.dims[0], N = c.shape.dims[1], K = c.shape.dims[2], S = K;
    const auto& v = c.values;
    const auto scaled = [](std::vector<double> g, float w) {
      for (double& x : g) x *= w;
      return g;
    };
    return std::vector<Expected>{grad_expected(scaled(ref_mse_area_grad(v[0], v[1], v[2], N, R, K), kW[1])), {}, {},
                                 grad_expected(scaled(ref_alpha_outside_grad(v[3], v[4], v[2], N, R, S), kW[2])), {},
                                 grad_expected(scaled(ref_order_grad(v[5], v[2], N, R), kW[3]))};
  };
  return e;
}

}  // namespace

void register_loss_ops(std::vector<OpEntry>& t) {
  t.push_back(mse_entry());
  t.push_back(weighted_sum_entry());
  t.push_back(masked_mse_entry());
  t.push_back(blending_loss_entry());
  t.push_back(alpha_loss_entry());
  t.push_back(novel_view_losses_entry());
  t.push_back(reference_losses_entry());
  t.push_back(reference_losses_from_sums_entry());
}

}  // namespace nova::test

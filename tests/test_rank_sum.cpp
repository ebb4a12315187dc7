// The sum over ranks (rank_sum.hpp) and the batch statistics built on it (kernels/
// rank_moments.cl), with two ranks as threads summing through the in-process reducer, each
// with its own runtime on the test device. The ranks hold odd numbers of rays (37 and 23, or
// 29 each). The op table runs the same ops in one process with two ranks of identical rays
// (twin_ranks_reducer.hpp, tests/op_table_ranks.cpp); the last case here checks that stand-in
// gives the bits of two such ranks as threads.
//
// A loss split over ranks is checked as the trainer uses it: the objective is the mean over
// ranks of their losses, and a value of one rank's rays gets that rank's gradient divided by
// the number of ranks (the trainer sums the gradients over ranks and divides by it).
#include <boost/test/unit_test.hpp>

#include <cmath>

#include "conventions_reference.hpp"
#include "free_space_reference.hpp"
#include "harness.hpp"
#include "loss_reference.hpp"
#include "nova/graph/executor.hpp"
#include "nova/loss/terms.hpp"
#include "nova/ops/tensor/rank_sum.hpp"
#include "thread_reducer.hpp"
#include "twin_ranks_reducer.hpp"

using namespace nova;
using namespace nova::test;

namespace {

void require_no_errors(const std::vector<std::string>& errors) {
  for (size_t r = 0; r < errors.size(); ++r) BOOST_TEST_REQUIRE(errors[r].empty(), "rank " << r << ": " << errors[r]);
}

template <class T>
std::vector<T> part(const std::vector<T>& v, size_t first, size_t count) {
  return std::vector<T>(v.begin() + static_cast<long>(first), v.begin() + static_cast<long>(first + count));
}

// Rays [first, first + count) of a free-space case.
FreeSpaceCase slice_case(const FreeSpaceCase& f, size_t first, size_t count) {
  FreeSpaceCase s = f;
  s.R = count;
  s.raw.clear(), s.delta.clear(), s.masks.clear(), s.noise.clear();
  for (size_t n = 0; n < f.N; ++n) {
    const size_t row = n * f.R + first;
    s.raw.insert(s.raw.end(), f.raw.begin() + static_cast<long>(row * f.S * f.C),
                 f.raw.begin() + static_cast<long>((row + count) * f.S * f.C));
    s.delta.insert(s.delta.end(), f.delta.begin() + static_cast<long>(row * f.S),
                   f.delta.begin() + static_cast<long>((row + count) * f.S));
    s.masks.insert(s.masks.end(), f.masks.begin() + static_cast<long>(row), f.masks.begin() + static_cast<long>(row + count));
    if (!f.noise.empty())
      s.noise.insert(s.noise.end(), f.noise.begin() + static_cast<long>(row * f.S),
                     f.noise.begin() + static_cast<long>((row + count) * f.S));
  }
  s.z = part(f.z, first * f.S, count * f.S);
  s.depth = part(f.depth, first, count);
  s.target = part(f.target, first, count);
  s.valid = part(f.valid, first, count);
  return s;
}

// Rays [first, first + count) of each of the `rows` rows of a [rows, R, width] array.
std::vector<float> ray_rows(const std::vector<float>& v, size_t rows, size_t R, size_t width, size_t first,
                            size_t count) {
  std::vector<float> out;
  for (size_t n = 0; n < rows; ++n)
    out.insert(out.end(), v.begin() + static_cast<long>((n * R + first) * width),
               v.begin() + static_cast<long>((n * R + first + count) * width));
  return out;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(rank_sum)

// Forward: every rank gets the float64 sum (two floats: exact to one rounding, rtol 1e-7).
// Backward: each rank's loss is mse(y, its own target), so dx = sum over ranks of 2 (y - t_k) / n,
// likewise to float rounding of a few operations (rtol 1e-6).
BOOST_AUTO_TEST_CASE(forward_and_adjoint_are_sums_over_ranks) {
  const size_t n = 7;
  std::vector<std::vector<float>> x = {random_floats(n, -1, 1, 1), random_floats(n, -1, 1, 2)};
  std::vector<std::vector<float>> target = {random_floats(n, -1, 1, 3), random_floats(n, -1, 1, 4)};
  std::vector<std::vector<float>> y(2), dx(2);
  require_no_errors(run_ranks(2, [&](int r, GradientReducer& ranks) {
    const size_t k = static_cast<size_t>(r);
    Runtime rt(test::runtime().info(), false);
    Graph g;
    Tensor tx = g.input("x", Shape{n}, true), tt = g.input("target", Shape{n});
    Tensor ty = nova::rank_sum(tx, ranks);
    g.keep(ty);
    g.set_loss(mse(ty, tt));
    Executor ex(rt, g);
    ex.set(tx, x[k]);
    ex.set(tt, target[k]);
    ex.forward();
    ex.backward();
    y[k] = ex.get(ty);
    dx[k] = ex.get_grad(tx);
  }));
  std::vector<double> y_ref(n), dx_ref(n, 0.0);
  for (size_t i = 0; i < n; ++i) {
    y_ref[i] = double(x[0][i]) + x[1][i];
    for (size_t k = 0; k < 2; ++k) dx_ref[i] += 2.0 * (y_ref[i] - target[k][i]) / n;
  }
  BOOST_TEST((y[0] == y[1]));  // the same bits on every rank
  BOOST_TEST((dx[0] == dx[1]));
  expect_close(y[0], y_ref, 0, 1e-7, "rank_sum forward");
  expect_close(dx[0], dx_ref, 1e-7, 1e-6, "rank_sum backward");
}

// The depth loss of 37 + 23 rays on two ranks against the float64 loss of all 60 (rtol 1e-4
// as test_depth_loss_op: float32 sums, here from moments, ~1e-6 relative) and against one
// process's single kernel on them; its gradient against the float64 reference's central
// differences (h = 1e-6, exact to ~1e-9; rtol 1e-3 and atol 1e-4 of the gradient's scale as
// the op table's entry of the single kernel, for the standardisation's cancellations) and against
// central differences of the split device forward itself (float32: h = 1e-2, the harness'
// 2e-2 of the gradient's scale).
BOOST_AUTO_TEST_CASE(depth_loss_over_ranks_is_the_whole_batchs) {
  const size_t R = 60;
  const size_t share[2] = {37, 23}, first[2] = {0, 37};
  const auto p = random_floats(R, 0.0f, 1.0f, 11), t = random_floats(R, -2.0f, 3.0f, 12);
  std::vector<float> w(R, 1.0f);
  for (size_t i = 0; i < R; i += 5) w[i] = 0.0f;
  const std::vector<size_t> probes = {1, 7, 36, 38, 59};  // rays of both ranks for the device differences
  const float h = 1e-2f;
  std::vector<float> loss(2), grad(R);
  std::vector<std::vector<float>> fd_loss(2);  // per probe: loss at +h, then at -h
  require_no_errors(run_ranks(2, [&](int r, GradientReducer& ranks) {
    const size_t k = static_cast<size_t>(r), a = first[k], m = share[k];
    Runtime rt(test::runtime().info(), false);
    Graph g;
    Tensor tp = g.input("depth", Shape{m}, true), tt = g.input("target", Shape{m}), tw = g.input("valid", Shape{m});
    g.set_loss(depth_loss(tp, tt, tw, &ranks));
    Executor ex(rt, g);
    auto mine = part(p, a, m);
    ex.set(tp, mine);
    ex.set(tt, part(t, a, m));
    ex.set(tw, part(w, a, m));
    ex.forward();
    ex.backward();
    loss[k] = ex.loss();
    const auto d = ex.get_grad(tp);
    for (size_t i = 0; i < m; ++i) grad[a + i] = d[i] / 2.0f;  // the trainer's mean over ranks
    // Every rank runs every probe's forwards (each a collective); the owner moves its ray.
    for (size_t q : probes)
      for (float s : {h, -h}) {
        auto moved = mine;
        if (q >= a && q < a + m) moved[q - a] += s;
        ex.set(tp, moved);
        ex.forward();
        fd_loss[k].push_back(ex.loss());
      }
  }));
  BOOST_TEST(loss[0] == loss[1]);  // every rank has the whole batch's loss
  const std::vector<double> pd = to_double(p);
  expect_close({loss[0]}, {ref_depth_loss(pd, t, w)}, 0, 1e-4, "depth_loss over two ranks");

  Graph g;
  Tensor tp = g.input("depth", Shape{R}, true), tt = g.input("target", Shape{R}), tw = g.input("valid", Shape{R});
  g.set_loss(depth_loss(tp, tt, tw));
  Executor ex(test::runtime(), g);
  ex.set(tp, p);
  ex.set(tt, t);
  ex.set(tw, w);
  ex.forward();
  ex.backward();
  BOOST_TEST(loss[0] == ex.loss(), boost::test_tools::tolerance(1e-5f));
  const std::vector<float> one = ex.get_grad(tp);

  const std::vector<double> fd = ref_depth_loss_gradient(pd, t, w);
  double scale = 0;
  for (double v : fd) scale = std::max(scale, std::fabs(v));
  expect_close(grad, fd, 1e-4 * scale, 1e-3, "d depth_loss / d depth over two ranks");
  expect_close(grad, to_double(one), 1e-4 * scale, 1e-3, "against one process");
  for (size_t i = 0; i < probes.size(); ++i) {
    // The objective is the mean over ranks of the losses (both equal here).
    const double d = (double(fd_loss[0][2 * i]) - fd_loss[0][2 * i + 1]) / (2.0 * h);
    BOOST_TEST(std::fabs(d - grad[probes[i]]) <= 2e-2 * (scale + 1e-6),
               "ray " << probes[i] << ": device difference " << d << ", gradient " << grad[probes[i]]);
  }
}

// The free-space loss of 2 NeRFs x (29 + 29) rays x 5 samples on two ranks: the mean over ranks
// of their losses against the float64 loss of the whole batch (one fit over all 58 rays; rtol
// 1e-4 as test_free_space_loss_op), and d raw (halved, the trainer's mean) against one process's
// (the same per-ray kernel with a fit from other float sums: rtol 1e-4, atol 1e-6 of the scale).
// The depth gets no gradient from this loss, also through the fit's moments.
BOOST_AUTO_TEST_CASE(free_space_fit_over_ranks_is_the_whole_batchs) {
  FreeSpaceCase f;
  f.N = 2, f.R = 58, f.S = 5;
  const size_t E = f.N * f.R * f.S;
  f.raw = random_floats(E * f.C, -1, 1, 21);
  const auto sig = random_floats(E, 0.3f, 4.0f, 22);
  for (size_t e = 0; e < E; ++e) f.raw[e * f.C + 3] = sig[e];
  f.delta = random_floats(E, 0.02f, 0.2f, 23);
  for (size_t r = 0; r < f.R; ++r)
    for (size_t i = 0; i < f.S; ++i) f.z.push_back((i + 0.5f) / f.S);
  f.depth = random_floats(f.R, 0.2f, 0.9f, 24);
  f.target = random_floats(f.R, -3.0f, -0.5f, 25);
  f.valid.assign(f.R, 1.0f);
  for (size_t r = 0; r < f.R; r += 6) f.valid[r] = 0.0f;
  f.masks = random_floats(f.N * f.R, 0, 1, 26);
  for (float& m : f.masks) m = m < 0.4f ? 0.0f : 1.0f;
  f.noise = random_floats(E, -0.1f, 0.1f, 27);

  const size_t half = f.R / 2;
  std::vector<FreeSpaceRun> runs(2);
  require_no_errors(run_ranks(2, [&](int r, GradientReducer& ranks) {
    const size_t k = static_cast<size_t>(r);
    Runtime rt(test::runtime().info(), false);
    runs[k] = run_free_space(slice_case(f, k * half, half), rt, true, &ranks);
  }));
  const double whole = free_space_reference(f, f.raw);
  expect_close({static_cast<float>((double(runs[0].loss) + runs[1].loss) / 2)}, {whole}, 0, 1e-4,
               "free_space_loss over two ranks");
  const FreeSpaceRun one = run_free_space(f, test::runtime(), true);
  std::vector<float> d_raw(f.raw.size());
  for (size_t k = 0; k < 2; ++k) {
    const FreeSpaceCase s = slice_case(f, k * half, half);
    for (size_t n = 0; n < f.N; ++n)
      for (size_t i = 0; i < half * f.S * f.C; ++i)
        d_raw[((n * f.R + k * half) * f.S) * f.C + i] = runs[k].d_raw[(n * half * f.S) * f.C + i] / 2.0f;
    // The depth feeds only the mse (d = 2 depth / R) besides the fit, which adds nothing.
    for (size_t i = 0; i < half; ++i)
      BOOST_TEST(runs[k].d_depth[i] == 2.0f * s.depth[i] / static_cast<float>(half),
                 boost::test_tools::tolerance(1e-6f));
  }
  double scale = 0;
  for (float v : one.d_raw) scale = std::max(scale, double(std::fabs(v)));
  expect_close(d_raw, to_double(one.d_raw), 1e-6 * scale, 1e-4, "d free_space_loss / d raw over two ranks");
}


// The op table's stand-in for a second rank (twin_ranks_reducer.hpp) against two ranks as
// threads holding the same rays: the same bits (a sum of two equal floats is exact either
// way) for the depth loss of 37 rays and the free-space loss of 2 NeRFs x 23 rays x 3, their
// gradients included.
BOOST_AUTO_TEST_CASE(twin_ranks_are_two_ranks_with_the_same_rays) {
  const size_t R = 37;
  const auto p = random_floats(R, 0.0f, 1.0f, 31), t = random_floats(R, -2.0f, 3.0f, 32);
  std::vector<float> w(R, 1.0f);
  for (size_t i = 0; i < R; i += 5) w[i] = 0.0f;
  const FreeSpaceCase f = free_space_table_case(2, 23, 3);
  const auto depth_run = [&](Runtime& rt, GradientReducer& ranks) {
    Graph g;
    Tensor tp = g.input("depth", Shape{R}, true), tt = g.input("target", Shape{R}), tw = g.input("valid", Shape{R});
    g.set_loss(depth_loss(tp, tt, tw, &ranks));
    Executor ex(rt, g);
    ex.set(tp, p);
    ex.set(tt, t);
    ex.set(tw, w);
    ex.forward();
    ex.backward();
    std::vector<float> out = ex.get_grad(tp);
    out.push_back(ex.loss());
    return out;
  };
  std::vector<std::vector<float>> depth(2);
  std::vector<FreeSpaceRun> free_space(2);
  require_no_errors(run_ranks(2, [&](int r, GradientReducer& ranks) {
    const size_t k = static_cast<size_t>(r);
    Runtime rt(test::runtime().info(), false);
    depth[k] = depth_run(rt, ranks);
    free_space[k] = run_free_space(f, rt, true, &ranks);
  }));
  TwinRanksReducer twin;
  const std::vector<float> depth_twin = depth_run(test::runtime(), twin);
  const FreeSpaceRun free_space_twin = run_free_space(f, test::runtime(), true, &twin);
  for (size_t k = 0; k < 2; ++k) {
    BOOST_TEST((depth[k] == depth_twin), "depth_loss: rank " << k);
    BOOST_TEST(free_space[k].loss == free_space_twin.loss, "free_space_loss: rank " << k);
    BOOST_TEST((free_space[k].d_raw == free_space_twin.d_raw), "d free_space_loss / d raw: rank " << k);
    BOOST_TEST((free_space[k].d_depth == free_space_twin.d_depth), "d depth: rank " << k);
  }
}

// The reference code's ratio losses (masked_mse_area with each NeRF's own target,
// alpha_loss_outside, order_loss) of 3 NeRFs x (29 + 29) rays on two ranks: each rank's value
// against the float64 loss of all 58 rays, whose mask areas and counts are the whole batch's
// (rtol 1e-5 as the op table's reference_losses: float32 sums of O(1) terms), and the gradients
// (halved, the trainer's mean over ranks) against the float64 derivatives of the whole batch's
// losses (rtol 1e-4, atol 1e-6 of the gradient's scale: one division more than one process).
BOOST_AUTO_TEST_CASE(reference_ratio_losses_over_ranks_are_the_whole_batchs) {
  const size_t N = 3, R = 58, K = 3, S = 4, half = R / 2;
  const auto pred = random_floats(N * R * K, 0, 1, 31), target = random_floats(N * R * K, 0, 1, 32);
  auto masks = random_floats(N * R, 0, 1, 33);
  for (float& m : masks) m = m < 0.4f ? 0.0f : m < 0.8f ? 1.0f : m;
  const auto raw = smooth_raw(N, R * S, 34), delta = random_floats(R * S, 0.05f, 0.5f, 35);
  const auto depth = random_floats(N * R, 0, 1, 36);
  std::vector<std::vector<float>> losses(2, std::vector<float>(3));
  std::vector<float> d_pred(pred.size()), d_raw(raw.size()), d_depth(depth.size());
  require_no_errors(run_ranks(2, [&](int r, GradientReducer& ranks) {
    const size_t k = static_cast<size_t>(r), a = k * half;
    Runtime rt(test::runtime().info(), false);
    Graph g;
    Tensor tp = g.input("pred", Shape{N, half, K}, true), tt = g.input("target", Shape{N, half, K}),
           tm = g.input("masks", Shape{N, half});
    Tensor ta = g.input("raw", Shape{N, half * S, 5}, true), td = g.input("delta", Shape{half, S});
    Tensor tdp = g.input("depth", Shape{N, half}, true);
    const std::vector<Tensor> terms = {masked_mse_area(tp, tt, tm, &ranks),
                                       alpha_loss_outside(ta, td, tm, Tensor{}, true, &ranks),
                                       order_loss(tdp, tm, &ranks)};
    for (const Tensor& t : terms) g.keep(t);
    g.set_loss(weighted_sum(terms, {1.0f, 1.0f, 1.0f}));
    Executor ex(rt, g);
    ex.set(tp, ray_rows(pred, N, R, K, a, half));
    ex.set(tt, ray_rows(target, N, R, K, a, half));
    ex.set(tm, ray_rows(masks, N, R, 1, a, half));
    ex.set(ta, ray_rows(raw, N, R, S * 5, a, half));
    ex.set(td, part(delta, a * S, half * S));
    ex.set(tdp, ray_rows(depth, N, R, 1, a, half));
    ex.forward();
    ex.backward();
    for (size_t i = 0; i < 3; ++i) losses[k][i] = ex.get(terms[i])[0];
    // Back into the whole batch's layout, halved: the trainer's mean over ranks.
    const auto place = [&](const std::vector<float>& mine, std::vector<float>& whole, size_t width) {
      for (size_t n = 0; n < N; ++n)
        for (size_t i = 0; i < half * width; ++i) whole[(n * R + a) * width + i] = mine[n * half * width + i] / 2.0f;
    };
    place(ex.get_grad(tp), d_pred, K);
    place(ex.get_grad(ta), d_raw, S * 5);
    place(ex.get_grad(tdp), d_depth, 1);
  }));
  BOOST_TEST((losses[0] == losses[1]));  // every rank has the whole batch's losses
  expect_close(losses[0],
               {ref_mse_area(pred, target, masks, N, R, K), ref_alpha_outside(raw, delta, masks, {}, N, R, S),
                ref_order(depth, masks, N, R)},
               1e-9, 1e-5, "ratio losses over two ranks");
  const auto check = [](const std::vector<float>& got, const std::vector<double>& want, const std::string& what) {
    double scale = 0;
    for (double v : want) scale = std::max(scale, std::fabs(v));
    expect_close(got, want, 1e-6 * scale, 1e-4, what);
  };
  check(d_pred, ref_mse_area_grad(pred, target, masks, N, R, K), "d masked_mse_area / d pred over two ranks");
  check(d_raw, ref_alpha_outside_grad(raw, delta, masks, N, R, S), "d alpha_loss_outside / d raw over two ranks");
  check(d_depth, ref_order_grad(depth, masks, N, R), "d order_loss / d depth over two ranks");
}

BOOST_AUTO_TEST_SUITE_END()

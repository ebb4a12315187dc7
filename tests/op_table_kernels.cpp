// The kernels that run outside graph ops, in the op table's suite so that its launch
// coverage sees them: optim.cl (adam_step), gemm.cl (nova's own GEMM provider) and
// termination.cl, each at sizes that leave a partial work-group, against float64 references.
#include <boost/test/unit_test.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "harness.hpp"
#include "nova/ops/linalg/gemm.hpp"
#include "nova/train/optim.hpp"
#include "nova/runtime/runtime.hpp"
#include "op_harness.hpp"
#include "op_table.hpp"

using namespace nova;
using namespace nova::test;

namespace {
constexpr size_t kRows = kOddRows;
Runtime& rt() { return runtime(); }
}  // namespace

BOOST_FIXTURE_TEST_SUITE(op_table, RecordLaunches)

// optim.cl: adam_step over 1009 parameters, two steps, against PyTorch's formulation in
// float64. Tolerance: each update is a few float32 operations on O(lr) values, rtol 1e-5 of
// the parameter plus 1e-6 of the learning rate.
BOOST_AUTO_TEST_CASE(optimiser) {
  Runtime& r = rt();
  auto p = random_floats(kRows, -1, 1, 141);
  const auto g1 = random_floats(kRows, -1, 1, 142), g2 = random_floats(kRows, -0.1f, 0.1f, 143);
  Buffer params = r.upload_floats(p), grads = r.upload_floats(g1);
  AdamConfig c;
  Adam adam(r, kRows, c);
  const float lr = 1e-2f;
  adam.step(params.get(), grads.get(), lr);
  r.upload(grads.get(), g2.data(), g2.size() * sizeof(float));
  adam.step(params.get(), grads.get(), lr);
  const auto got = r.download_floats(params.get(), kRows);
  std::vector<double> want(kRows);
  for (size_t i = 0; i < kRows; ++i) {
    double x = p[i], m = 0, v = 0;
    int t = 0;
    for (double gi : {double(g1[i]), double(g2[i])}) {
      ++t;
      m = c.beta1 * m + (1 - c.beta1) * gi;
      v = c.beta2 * v + (1 - c.beta2) * gi * gi;
      const double mhat = m / (1 - std::pow(double(c.beta1), t));
      const double vhat = v / (1 - std::pow(double(c.beta2), t));
      x -= lr * mhat / (std::sqrt(vhat) + c.eps);
    }
    want[i] = x;
  }
  expect_close(got, want, 1e-6 * lr, 1e-5, "adam");
}

// optim.cl: a range of the parameters at a quarter of the rate (Adam::scale_range), one step
// from zero moments: the first step moves each parameter by -rate * sign(g) (PyTorch's
// formulation, float64), so inside the range a quarter as far. Tolerance as above.
BOOST_AUTO_TEST_CASE(optimiser_scaled_range) {
  Runtime& r = rt();
  const auto p = random_floats(kRows, -1, 1, 144), g = random_floats(kRows, -1, 1, 145);
  Buffer params = r.upload_floats(p), grads = r.upload_floats(g);
  AdamConfig c;
  Adam adam(r, kRows, c);
  const size_t first = 100, count = 300;
  adam.scale_range(first, count, 0.25f);
  const float lr = 1e-2f;
  adam.step(params.get(), grads.get(), lr);
  const auto got = r.download_floats(params.get(), kRows);
  std::vector<double> want(kRows);
  for (size_t i = 0; i < kRows; ++i) {
    const double rate = i >= first && i < first + count ? 0.25 * lr : lr, gi = g[i];
    want[i] = p[i] - rate * gi / (std::fabs(gi) + c.eps);
  }
  expect_close(got, want, 1e-6 * lr, 1e-5, "adam, scaled range");
  BOOST_CHECK_THROW(adam.scale_range(kRows - 10, 11, 0.5f), Error);
}

// gemm.cl (the opt-in provider NOVA_GEMM=kernels): gemm_nn (1009 x 21 = A[1009, 5] B),
// gemm_tn (A^T B, 3 batches of 13 x 1009) and gemm_transpose + gemm_nn (A B^T, 3 batches of
// 11 x 999), with alpha and beta != 0, against float64 products; the same three through the
// blocked kernel (gemm_blk, gemm_reduce for split reductions). Tolerance as test_ops'
// linear: k <= 7 products of values in [-1, 1], |err| < 1e-5.
BOOST_AUTO_TEST_CASE(own_gemm_kernels) {
  Runtime& r = rt();
  const GemmProvider before = gemm_provider(r);
  set_gemm_provider(r, GemmProvider::Kernels);
  struct Case {
    bool ta, tb;
    size_t m, n, k, batch;
  };
  for (const Case c : {Case{false, false, kRows, 21, 5, 1}, Case{true, false, 13, kRows, 7, 3},
                       Case{false, true, 11, 999, 3, 3}}) {
    BOOST_TEST_CONTEXT("trans_a " << c.ta << " trans_b " << c.tb << ", " << c.m << " x " << c.n
                                  << " x " << c.k << ", batch " << c.batch) {
      const size_t sa = c.m * c.k, sb = c.k * c.n, sc = c.m * c.n;
      const auto a = random_floats(c.batch * sa, -1, 1, 171), b = random_floats(c.batch * sb, -1, 1, 172);
      const auto c0 = random_floats(c.batch * sc, -1, 1, 173);
      Buffer da = r.upload_floats(a), db = r.upload_floats(b), dc = r.upload_floats(c0);
      const float alpha = 0.5f, beta = 0.25f;
      GemmArgs g{c.ta, c.tb, c.m, c.n, c.k, alpha, da.get(), c.ta ? c.m : c.k, sa, db.get(),
                 c.tb ? c.k : c.n, sb, beta, dc.get(), c.n, sc, c.batch};
      std::vector<std::vector<float>> results;
      {
        Buffer temp;
        if (size_t bytes = gemm_temp_bytes(r, g)) temp = r.alloc(bytes);
        gemm(r, g, temp.get());
        results.push_back(r.download_floats(dc.get(), c.batch * sc));
      }
      // The blocked kernel (gemm_blk), with a split reduction (gemm_reduce) of ragged chunks
      // and A^T packed first (gemm_transpose) where A is transposed.
      for (const char* text : {"blocked RM=6 VN=2 KC=3 TA=1", "blocked RM=4 VN=1 KC=2"}) {
        r.upload(dc.get(), c0.data(), c0.size() * sizeof(float));
        const GemmConfig cfg = GemmConfig::parse(text);
        Buffer temp;
        if (size_t bytes = gemm_temp_bytes_with(r, cfg, g)) temp = r.alloc(bytes);
        gemm_with(r, cfg, g, temp.get());
        results.push_back(r.download_floats(dc.get(), c.batch * sc));
      }
      std::vector<double> want(c.batch * sc);
      for (size_t p = 0; p < c.batch; ++p)
        for (size_t i = 0; i < c.m; ++i)
          for (size_t j = 0; j < c.n; ++j) {
            double s = 0;
            for (size_t l = 0; l < c.k; ++l) {
              const double x = a[p * sa + (c.ta ? l * c.m + i : i * c.k + l)];
              const double y = b[p * sb + (c.tb ? j * c.k + l : l * c.n + j)];
              s += x * y;
            }
            want[p * sc + i * c.n + j] = alpha * s + beta * double(c0[p * sc + i * c.n + j]);
          }
      for (const auto& got : results) expect_close(got, want, 1e-5, 0, "own gemm kernels");
    }
  }
  set_gemm_provider(r, before);
}

// termination.cl: a chunk of kRows rays (the last 5 padding) in two segments with random
// segment composites, against a float64 replay of C = C_1 + T_1 C_2 and the open/stopped
// counts. Each output is one or two float32 products and sums: rtol 1e-6, atol 1e-7.
BOOST_AUTO_TEST_CASE(termination_kernels) {
  Runtime& r = rt();
  const size_t R = kRows, n = kRows - 5, N = 2;
  const float below = 0.3f;
  auto buf = [&](size_t bytes) { return r.alloc(bytes); };
  Buffer T = buf(R * 4), open = buf(R), was = buf(R), counts = buf(8), rgb = buf(R * 12), depth = buf(R * 4),
         acc = buf(R * 4), mask = buf(N * R * 4);
  r.launch("termination", "termination_start").arg(T).arg(open).arg(rgb).arg(depth).arg(acc).arg(mask)
      .arg(unsigned(R)).arg(unsigned(n)).arg(unsigned(N)).run(R);
  std::vector<double> t_ref(R), rgb_ref(R * 3, 0.0), depth_ref(R, 0.0), acc_ref(R, 0.0), mask_ref(N * R, 0.0);
  for (size_t i = 0; i < R; ++i) t_ref[i] = i < n ? 1.0 : 0.0;
  std::vector<uint8_t> open_ref(R, 0);
  for (int k = 0; k < 2; ++k) {
    r.launch("termination", "termination_open").arg(T).arg(open).arg(was).arg(unsigned(R)).arg(below).run(R);
    r.launch("termination", "termination_count").arg(open).arg(was).arg(counts).arg(unsigned(R)).arg(int(k == 0)).run(1);
    uint32_t got[2];
    r.download(counts.get(), got, sizeof(got));
    size_t live = 0, stopped = 0;
    for (size_t i = 0; i < R; ++i) {
      const bool now = t_ref[i] >= below;
      stopped += k > 0 && open_ref[i] && !now;
      open_ref[i] = now;
      live += now;
    }
    BOOST_TEST(got[0] == live);
    BOOST_TEST(got[1] == stopped);
    // Segment composites: acc in [0, 1.2] so that some rays close (T < 0.3) after the first.
    const auto s_rgb = random_floats(R * 3, 0, 1, 140 + k), s_depth = random_floats(R, 0, 1, 142 + k),
               s_acc = random_floats(R, 0, 1.2f, 144 + k), s_mask = random_floats(N * R, 0, 1, 146 + k);
    Buffer a = r.upload_floats(s_rgb), b = r.upload_floats(s_depth), c = r.upload_floats(s_acc), d = r.upload_floats(s_mask);
    r.launch("termination", "termination_accumulate").arg(a).arg(b).arg(c).arg(d).arg(open).arg(T).arg(rgb).arg(depth)
        .arg(acc).arg(mask).arg(unsigned(R)).arg(unsigned(N)).run(R);
    for (size_t i = 0; i < R; ++i) {
      if (!open_ref[i]) continue;
      const double t = t_ref[i];
      for (size_t j = 0; j < 3; ++j) rgb_ref[i * 3 + j] += t * s_rgb[i * 3 + j];
      depth_ref[i] += t * s_depth[i];
      acc_ref[i] += t * s_acc[i];
      for (size_t m = 0; m < N; ++m) mask_ref[m * R + i] += t * s_mask[m * R + i];
      t_ref[i] = t * std::max(0.0, 1.0 - double(s_acc[i]));
    }
  }
  expect_close(r.download_floats(T.get(), R), t_ref, 1e-7, 1e-6, "termination T");
  expect_close(r.download_floats(rgb.get(), R * 3), rgb_ref, 1e-7, 1e-6, "termination rgb");
  expect_close(r.download_floats(depth.get(), R), depth_ref, 1e-7, 1e-6, "termination depth");
  expect_close(r.download_floats(acc.get(), R), acc_ref, 1e-7, 1e-6, "termination acc");
  expect_close(r.download_floats(mask.get(), N * R), mask_ref, 1e-7, 1e-6, "termination masks");
}

BOOST_AUTO_TEST_SUITE_END()

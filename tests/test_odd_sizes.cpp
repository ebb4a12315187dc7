// Every kernel of kernels/*.cl launched at a problem size that is no multiple of any
// work-group size, and checked there against a float64 host reference (portable
// kernels). The runtime rounds the global size up to the queried work-group size and every
// kernel guards with its own count; a missing guard, a wrong count or a skipped last group
// shows up here as a wrong element in the last, partial work-group.
//
// Sizes: 1009 rows (a prime, more than any work-group nova chooses, so several groups and a
// partial last one on every device), odd widths (3, 5, 7) and odd part counts. The last test
// reads the runtime's launch log and fails if any kernel of any embedded family was not
// launched here with every dimension either ragged or of work-group extent 1: a new kernel
// must be added to this sweep (or to kCoveredElsewhere with the suite that does it).
//
// Tolerances: forward values as the op suites state them (test_ops, test_losses, test_rays,
// test_render), restated next to each check. Gradients are checked element by element
// against the float64 derivative applied to the upstream gradient of the mse loss
// (2 (out - target) / n, taken from the device output): float32 rounding of one product
// chain is a few 1e-7 relative, so rtol 1e-5 with atol 1e-6 of the gradient's scale.
#include <boost/test/unit_test.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "free_space_reference.hpp"
#include "harness.hpp"
#include "loss_reference.hpp"
#include "nova/compose_spec.hpp"
#include "nova/gemm.hpp"
#include "nova/kernel_sources.hpp"
#include "nova/losses.hpp"
#include "nova/ops.hpp"
#include "nova/optim.hpp"
#include "nova/random.hpp"
#include "nova/rays.hpp"
#include "nova/render.hpp"
#include "conventions_reference.hpp"
#include "rays_reference.hpp"
#include "random_reference.hpp"
#include "render_check.hpp"

using namespace nova;
using namespace nova::test;
namespace utf = boost::unit_test;

namespace {

constexpr size_t kRows = 1009;  // prime: no multiple of any work-group size

// Families whose kernels another suite runs at odd sizes (kept out of this sweep so that the
// op's own tests stay the one place that knows its interface).
const std::map<std::string, std::string> kCoveredElsewhere = {
    {"distortion", "tests/test_distortion_loss_op.cpp (3 NeRFs x 6 rays x 9 samples)"},
    {"hashgrid", "tests/test_hashgrid.cpp (rows 37, 23 and 19)"},
    {"packing", "tests/test_packing.cpp (1009 rows per batch)"},
    {"rank_moments", "tests/test_rank_sum.cpp (37 + 23 and 29 + 29 rays over two ranks)"},
};

Runtime& rt() {
  Runtime& r = runtime();
  r.record_launches(true);
  return r;
}

// Upstream gradient of mse(out, target): 2 (out - target) / n, from the device output.
std::vector<double> mse_upstream(const std::vector<float>& out, const std::vector<float>& target) {
  std::vector<double> g(out.size());
  for (size_t i = 0; i < out.size(); ++i)
    g[i] = 2.0 * (double(out[i]) - target[i]) / double(out.size());
  return g;
}

double max_abs(const std::vector<double>& v) {
  double m = 1e-30;
  for (double x : v) m = std::max(m, std::fabs(x));
  return m;
}

// Gradient check: rtol 1e-5 and atol 1e-6 of the largest reference magnitude (header).
void expect_grad_close(const std::vector<float>& got, const std::vector<double>& want,
                       const std::string& what) {
  expect_close(got, want, 1e-6 * max_abs(want), 1e-5, what);
}


double act_slope(Activation a, double x) {
  switch (a) {
    case Activation::ReLU: return x > 0 ? 1 : 0;
    case Activation::Sigmoid: {
      const double s = 1 / (1 + std::exp(-x));
      return s * (1 - s);
    }
    case Activation::Softplus: return 1 / (1 + std::exp(-x));
    default: return 1;
  }
}

// A launch covers its kernel when, in every dimension, the problem size leaves a partial
// work-group (or the group is 1 wide there, where nothing can be partial); on a device whose
// work-groups are all 1 wide, an odd size.
bool ragged(const LaunchRecord& r) {
  bool any_wide = false;
  for (size_t d = 0; d < r.dims; ++d) {
    if (r.local[d] > 1 && r.size[d] % r.local[d] == 0) return false;
    any_wide = any_wide || r.local[d] > 1;
  }
  return any_wide || r.size[0] % 2 == 1;
}

// Kernel names of one embedded source: `__kernel void NAME(` with comments removed.
std::vector<std::string> kernel_names(std::string_view source) {
  std::string text(source);
  text = std::regex_replace(text, std::regex(R"(/\*[\s\S]*?\*/)"), " ");
  text = std::regex_replace(text, std::regex(R"(//[^\n]*)"), " ");
  std::vector<std::string> names;
  const std::regex kernel(R"((?:__kernel|\bkernel)\s+void\s+(\w+)\s*\()");
  for (std::sregex_iterator it(text.begin(), text.end(), kernel), end; it != end; ++it)
    names.push_back((*it)[1]);
  return names;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(odd_sizes)

// encoding.cl: posenc_forward / posenc_backward over 1009 x 3 inputs, L = 4.
BOOST_AUTO_TEST_CASE(encoding) {
  const size_t dims = 3;
  const int L = 4;
  const auto p = random_floats(kRows * dims, -1.5f, 1.5f, 101);
  Graph g;
  Tensor x = g.input("p", Shape{kRows, dims}, true);
  Tensor y = positional_encoding(x, L);
  Tensor target = g.input("target", y.shape());
  g.keep(y);
  g.set_loss(mse(y, target));
  Executor ex(rt(), g);
  const auto t = random_floats(y.shape().numel(), -1, 1, 102);
  ex.set(x, p);
  ex.set(target, t);
  ex.forward();
  ex.backward();
  const auto out = ex.get(y);
  const auto dp = ex.get_grad(x);
  const size_t width = dims * (1 + 2 * L);
  std::vector<double> ref(out.size()), dref(p.size());
  const auto up = mse_upstream(out, t);
  for (size_t r = 0; r < kRows; ++r)
    for (size_t d = 0; d < dims; ++d) {
      const double v = p[r * dims + d];
      ref[r * width + d] = v;
      double grad = up[r * width + d];
      for (int k = 0; k < L; ++k) {
        const double f = std::ldexp(1.0, k);
        const size_t s = r * width + dims * (1 + 2 * k) + d, c = s + dims;
        ref[s] = std::sin(f * v);
        ref[c] = std::cos(f * v);
        grad += f * (std::cos(f * v) * up[s] - std::sin(f * v) * up[c]);
      }
      dref[r * dims + d] = grad;
    }
  // sin/cos of arguments up to 12: a few ulp of values <= 1 (test_ops).
  expect_close(out, ref, 1e-6, 1e-6, "positional encoding");
  expect_grad_close(dp, dref, "d positional encoding / d p");
}

// activation.cl: bias_act_forward / _backward and bias_grad_partial (2D: 7 or 21 columns x 15
// row parts); reduce.cl: colsum_finish. Every activation, one and three networks.
BOOST_AUTO_TEST_CASE(activation_and_reduce) {
  const size_t cols = 7;
  for (Activation a : {Activation::Identity, Activation::ReLU, Activation::Sigmoid,
                       Activation::Softplus})
    for (size_t batch : {size_t{1}, size_t{3}}) {
      BOOST_TEST_CONTEXT(activation_name(a) << ", batch " << batch) {
        auto h = random_floats(batch * kRows * cols, -3, 3, 111);
        const auto b = random_floats(batch * cols, -1, 1, 112);
        const auto bias = [&](size_t i) { return b[(i / (kRows * cols)) * cols + i % cols]; };
        // Keep h + b 1e-3 from ReLU's kink, where float32 and float64 could disagree on the side.
        for (size_t i = 0; i < h.size(); ++i)
          if (std::fabs(h[i] + bias(i)) < 1e-3f) h[i] = 1e-3f - bias(i);
        Graph g;
        Tensor th = g.input("h", batch > 1 ? Shape{batch, kRows, cols} : Shape{kRows, cols}, true);
        Tensor tb = g.input("b", batch > 1 ? Shape{batch, cols} : Shape{cols}, true);
        Tensor y = bias_act(th, tb, a);
        Tensor target = g.input("target", y.shape());
        g.keep(y);
        g.set_loss(mse(y, target));
        Executor ex(rt(), g);
        const auto t = random_floats(h.size(), -1, 1, 113);
        ex.set(th, h);
        ex.set(tb, b);
        ex.set(target, t);
        ex.forward();
        ex.backward();
        const auto out = ex.get(y), dh = ex.get_grad(th), db = ex.get_grad(tb);
        const auto up = mse_upstream(out, t);
        std::vector<double> ref(h.size()), dh_ref(h.size()), db_ref(b.size(), 0.0),
            db_abs(b.size(), 0.0);
        for (size_t i = 0; i < h.size(); ++i) {
          const double x = double(h[i]) + bias(i);
          ref[i] = test::activation_reference(a, x);
          dh_ref[i] = up[i] * act_slope(a, x);
          const size_t bi = (i / (kRows * cols)) * cols + i % cols;
          db_ref[bi] += dh_ref[i];
          db_abs[bi] += std::fabs(dh_ref[i]);
        }
        // Forward as test_ops: one rounding of the sum, <= 4 ulp for exp/log1p.
        expect_close(out, ref, 1e-6, 1e-5, "bias_act forward");
        expect_grad_close(dh, dh_ref, "d bias_act / d h");
        // The bias gradient is a float32 two-stage sum of 1009 terms: error <= 1e-5 of the
        // sum of their magnitudes.
        expect_close(db, db_ref, 1e-5 * *std::max_element(db_abs.begin(), db_abs.end()), 0,
                     "d bias_act / d b");
      }
    }
}

// tensor.cl: copy_cols / copy_cols_back (concat of 3 + 5 columns: 3027 and 5045 elements).
BOOST_AUTO_TEST_CASE(tensor_copies) {
  const auto a = random_floats(kRows * 3, -1, 1, 121), b = random_floats(kRows * 5, -1, 1, 122);
  Graph g;
  Tensor ta = g.input("a", Shape{kRows, 3}, true), tb = g.input("b", Shape{kRows, 5}, true);
  Tensor y = concat({ta, tb});
  Tensor target = g.input("target", y.shape());
  g.keep(y);
  g.set_loss(mse(y, target));
  Executor ex(rt(), g);
  const auto t = random_floats(kRows * 8, -1, 1, 123);
  ex.set(ta, a);
  ex.set(tb, b);
  ex.set(target, t);
  ex.forward();
  ex.backward();
  const auto out = ex.get(y), da = ex.get_grad(ta), db = ex.get_grad(tb);
  const auto up = mse_upstream(out, t);
  std::vector<double> ref, da_ref, db_ref;
  for (size_t r = 0; r < kRows; ++r) {
    for (size_t c = 0; c < 3; ++c) ref.push_back(a[r * 3 + c]), da_ref.push_back(up[r * 8 + c]);
    for (size_t c = 0; c < 5; ++c) ref.push_back(b[r * 5 + c]), db_ref.push_back(up[r * 8 + 3 + c]);
  }
  expect_close(out, ref, 0, 0, "concat is an exact copy");
  expect_grad_close(da, da_ref, "d concat / d a");
  expect_grad_close(db, db_ref, "d concat / d b");

  // gradient_gate (copy_cols forward, gate_rows_back) on [kRows * 3, 5] with a [2, kRows] gate.
  const auto x = random_floats(kRows * 15, -1, 1, 124), gt = random_floats(kRows * 15, -1, 1, 125);
  auto gate = random_floats(2 * kRows, 0, 1, 126);
  for (float& v : gate) v = v < 0.5f ? 0.0f : v;
  Graph gg;
  Tensor tx = gg.input("x", Shape{kRows * 3, 5}, true), tg = gg.input("gate", Shape{2, kRows});
  Tensor gy = gradient_gate(tx, tg, 1);
  Tensor gtarget = gg.input("target", gy.shape());
  gg.keep(gy);
  gg.set_loss(mse(gy, gtarget));
  Executor gex(rt(), gg);
  gex.set(tx, x);
  gex.set(tg, gate);
  gex.set(gtarget, gt);
  gex.forward();
  gex.backward();
  const auto gout = gex.get(gy);
  const auto gup = mse_upstream(gout, gt);
  std::vector<double> dx_ref(x.size());
  for (size_t i = 0; i < x.size(); ++i) dx_ref[i] = gup[i] * gate[kRows + i / 15];
  expect_close(gout, test::to_double(x), 0, 0, "gradient_gate forward is an exact copy");
  expect_grad_close(gex.get_grad(tx), dx_ref, "d gradient_gate / d x");

  // repeat_rows [3, 2] -> [3, kRows, 2] (a copy: exact), and random.cl's two draws of kRows
  // values: uniform is exact; normal's log/sqrt/cos/sin are within 4 ulp each (2e-6 + 2e-6 |x|,
  // as tests/test_device_random.cpp states).
  const auto small = random_floats(6, -1, 1, 127);
  Graph rg;
  Tensor ts = rg.input("per_batch", Shape{3, 2});
  Tensor rep = repeat_rows(ts, kRows);
  auto counter = std::make_shared<DrawCounter>();
  counter->value = 3;
  Tensor u = random_uniform(rg, "u", Shape{kRows}, {5, 1, counter});
  Tensor z = random_normal(rg, "z", Shape{kRows}, {5, 2, counter});
  for (Tensor t : {rep, u, z}) rg.keep(t);
  Executor rex(rt(), rg);
  rex.set(ts, small);
  rex.forward();
  std::vector<double> rep_ref, u_ref, z_ref;
  for (size_t b = 0; b < 3; ++b)
    for (size_t r = 0; r < kRows; ++r) rep_ref.push_back(small[b * 2]), rep_ref.push_back(small[b * 2 + 1]);
  for (size_t i = 0; i < kRows; ++i) {
    u_ref.push_back(test::random_reference(false, i, 5, 1, 3));
    z_ref.push_back(test::random_reference(true, i, 5, 2, 3));
  }
  expect_close(rex.get(rep), rep_ref, 0, 0, "repeat_rows is an exact copy");
  expect_close(rex.get(u), u_ref, 0, 0, "random_uniform");
  expect_close(rex.get(z), z_ref, 2e-6, 2e-6, "random_normal");
}

// loss.cl: every loss forward and backward (mse: sq_err_*; masked_mse: masked_sq_err_*;
// blending_loss: blend_sum_*; alpha_loss: alpha_outside_*), summed by weighted_sum
// (scalar_axpy, overwrite and accumulate) and finished by sum_finish.
BOOST_AUTO_TEST_CASE(losses) {
  const size_t G = 3, K = 3, N = 3, S = 3;
  const float w[4] = {0.7f, 1.3f, 0.4f, 2.1f};
  const auto pred = random_floats(G * kRows * K, 0, 1, 131), target = random_floats(kRows * K, 0, 1, 132);
  auto mask = random_floats(G * kRows, 0, 1, 133);
  for (float& m : mask) m = m < 0.4f ? 0.0f : m < 0.8f ? 1.0f : m;  // binary and soft
  const auto braw = smooth_raw(N, kRows, 134);
  const auto araw = smooth_raw(N, kRows * S, 135);
  const auto delta = random_floats(kRows * S, 0.05f, 0.5f, 136);
  auto masks = random_floats(N * kRows, 0, 1, 137);
  for (float& m : masks) m = m < 0.5f ? 0.0f : 1.0f;
  const auto p2 = random_floats(kRows * 7, -2, 2, 138), t2 = random_floats(kRows * 7, -2, 2, 139);

  Graph g;
  Tensor tp = g.input("pred", Shape{G, kRows, K}, true), tt = g.input("target", Shape{kRows, K}),
         tm = g.input("mask", Shape{G, kRows});
  Tensor tb = g.input("blend_raw", Shape{N, kRows, 5}, true);
  Tensor ta = g.input("alpha_raw", Shape{N, kRows * S, 5}, true),
         td = g.input("delta", Shape{kRows, S}), tms = g.input("masks", Shape{N, kRows});
  Tensor tp2 = g.input("p2", Shape{kRows, 7}, true), tt2 = g.input("t2", Shape{kRows, 7}, true);
  const Tensor terms[4] = {masked_mse(tp, tt, tm), blending_loss(tb), alpha_loss(ta, td, tms),
                           mse(tp2, tt2)};
  for (const Tensor& x : terms) g.keep(x);
  Tensor total = weighted_sum({terms[0], terms[1], terms[2], terms[3]}, {w[0], w[1], w[2], w[3]});
  g.set_loss(total);
  Executor ex(rt(), g);
  ex.set(tp, pred);
  ex.set(tt, target);
  ex.set(tm, mask);
  ex.set(tb, braw);
  ex.set(ta, araw);
  ex.set(td, delta);
  ex.set(tms, masks);
  ex.set(tp2, p2);
  ex.set(tt2, t2);
  ex.forward();
  ex.backward();

  double mse_ref = 0;
  for (size_t i = 0; i < p2.size(); ++i) mse_ref += (double(p2[i]) - t2[i]) * (double(p2[i]) - t2[i]);
  mse_ref /= double(p2.size());
  const double ref[4] = {ref_masked_mse(pred, target, mask, G, kRows, K),
                         ref_blending(braw, N, kRows), ref_alpha(araw, delta, masks, N, kRows, S),
                         mse_ref};
  // Float32 two-stage sums of a few thousand O(1) terms: rtol 1e-5, atol 1e-7 (test_losses).
  const char* names[4] = {"masked_mse", "blending_loss", "alpha_loss", "mse"};
  double total_ref = 0;
  for (int k = 0; k < 4; ++k) {
    expect_close(ex.get(terms[k]), {ref[k]}, 1e-7, 1e-5, names[k]);
    total_ref += w[k] * ref[k];
  }
  expect_close({ex.loss()}, {total_ref}, 1e-7, 1e-5, "weighted_sum");

  // d/dpred: 2 mask (pred - target) / (G R K).
  std::vector<double> dpred(pred.size());
  for (size_t gi = 0; gi < G; ++gi)
    for (size_t r = 0; r < kRows; ++r)
      for (size_t k = 0; k < K; ++k) {
        const size_t e = (gi * kRows + r) * K + k;
        dpred[e] = w[0] * 2.0 * mask[gi * kRows + r] * (double(pred[e]) - target[r * K + k]) /
                   double(G * kRows * K);
      }
  expect_grad_close(ex.get_grad(tp), dpred, "d masked_mse / d pred");
  // d/draw blend channel: sign(sum_n sigmoid(b) - 1) sigmoid'(b) / M; other channels 0.
  std::vector<double> dblend(braw.size(), 0.0);
  for (size_t m = 0; m < kRows; ++m) {
    double sum = 0;
    for (size_t n = 0; n < N; ++n) sum += loss_sigmoid(braw[(n * kRows + m) * 5 + 4]);
    for (size_t n = 0; n < N; ++n) {
      const double s = loss_sigmoid(braw[(n * kRows + m) * 5 + 4]);
      dblend[(n * kRows + m) * 5 + 4] = w[1] * (sum > 1 ? 1.0 : -1.0) * s * (1 - s) / double(kRows);
    }
  }
  expect_grad_close(ex.get_grad(tb), dblend, "d blending_loss / d raw");
  // Object NeRFs n >= 1 outside their mask: d alpha / d sigma = delta exp(-sigma delta) where
  // sigma > 0, and sigmoid' for the blend; the static NeRF's rows are 0.
  std::vector<double> dalpha(araw.size(), 0.0);
  const double denom = double((N - 1) * kRows * S);
  for (size_t n = 1; n < N; ++n)
    for (size_t r = 0; r < kRows; ++r)
      for (size_t i = 0; i < S; ++i) {
        const size_t at = (n * kRows + r) * S + i;
        const double out = 1.0 - masks[n * kRows + r], d = delta[r * S + i];
        const double sigma = araw[at * 5 + 3], s = loss_sigmoid(araw[at * 5 + 4]);
        dalpha[at * 5 + 3] = sigma > 0 ? w[2] * out * d * std::exp(-sigma * d) / denom : 0.0;
        dalpha[at * 5 + 4] = w[2] * out * s * (1 - s) / denom;
      }
  expect_grad_close(ex.get_grad(ta), dalpha, "d alpha_loss / d raw");
  std::vector<double> dp2(p2.size()), dt2(p2.size());
  for (size_t i = 0; i < p2.size(); ++i) {
    dp2[i] = w[3] * 2.0 * (double(p2[i]) - t2[i]) / double(p2.size());
    dt2[i] = -dp2[i];
  }
  expect_grad_close(ex.get_grad(tp2), dp2, "d mse / d pred");
  expect_grad_close(ex.get_grad(tt2), dt2, "d mse / d target");
}

// refloss.cl: the reference code's loss terms (mask_l1_loss: abs_err_*; masked_mse_area:
// masked_sq_err_group_*; alpha_loss_outside: alpha_outside_group_*; order_loss: order_*;
// the last three finished by group_ratio_finish / group_ratio_factor) over 1009 rays, the
// gradients against their float64 derivatives. Tolerances as the losses case above.
BOOST_AUTO_TEST_CASE(reference_losses) {
  const size_t N = 3, K = 3, S = 3;
  const float w[4] = {0.7f, 1.3f, 0.4f, 2.1f};
  const auto mtarget = random_floats(N * kRows, 0, 1, 191), mpred = random_floats(N * kRows, 0, 1, 192);
  const auto pred = random_floats(N * kRows * K, 0, 1, 193), target = random_floats(N * kRows * K, 0, 1, 194);
  auto mask = random_floats(N * kRows, 0, 1, 195);
  for (float& m : mask) m = m < 0.4f ? 0.0f : m < 0.8f ? 1.0f : m;
  const auto araw = smooth_raw(N, kRows * S, 196);
  const auto delta = random_floats(kRows * S, 0.05f, 0.5f, 197);
  const auto depth = random_floats(N * kRows, 0, 1, 198);

  Graph g;
  Tensor tmp = g.input("mpred", Shape{N, kRows}, true), tmt = g.input("mtarget", Shape{N, kRows});
  Tensor tp = g.input("pred", Shape{N, kRows, K}, true), tt = g.input("target", Shape{N, kRows, K}),
         tm = g.input("mask", Shape{N, kRows});
  Tensor ta = g.input("alpha_raw", Shape{N, kRows * S, 5}, true), td = g.input("delta", Shape{kRows, S});
  Tensor tdp = g.input("depth", Shape{N, kRows}, true);
  const Tensor terms[4] = {mask_l1_loss(tmp, tmt), masked_mse_area(tp, tt, tm),
                           alpha_loss_outside(ta, td, tm), order_loss(tdp, tm)};
  for (const Tensor& x : terms) g.keep(x);
  g.set_loss(weighted_sum({terms[0], terms[1], terms[2], terms[3]}, {w[0], w[1], w[2], w[3]}));
  Executor ex(rt(), g);
  ex.set(tmp, mpred);
  ex.set(tmt, mtarget);
  ex.set(tp, pred);
  ex.set(tt, target);
  ex.set(tm, mask);
  ex.set(ta, araw);
  ex.set(td, delta);
  ex.set(tdp, depth);
  ex.forward();
  ex.backward();
  const double ref[4] = {ref_mask_l1(mpred, mtarget, N, kRows), ref_mse_area(pred, target, mask, N, kRows, K),
                         ref_alpha_outside(araw, delta, mask, {}, N, kRows, S), ref_order(depth, mask, N, kRows)};
  const char* names[4] = {"mask_l1_loss", "masked_mse_area", "alpha_loss_outside", "order_loss"};
  for (int k = 0; k < 4; ++k) expect_close(ex.get(terms[k]), {ref[k]}, 1e-9, 1e-5, names[k]);

  std::vector<double> dm(mpred.size());
  for (size_t e = 0; e < dm.size(); ++e) {
    const double d = double(mpred[e]) - mtarget[e];
    dm[e] = w[0] * (d > 0 ? 1.0 : d < 0 ? -1.0 : 0.0) / double(kRows);
  }
  expect_grad_close(ex.get_grad(tmp), dm, "d mask_l1_loss / d mask");
  auto dp = ref_mse_area_grad(pred, target, mask, N, kRows, K);
  for (double& x : dp) x *= w[1];
  expect_grad_close(ex.get_grad(tp), dp, "d masked_mse_area / d pred");
  auto da = ref_alpha_outside_grad(araw, delta, mask, N, kRows, S);
  for (double& x : da) x *= w[2];
  expect_grad_close(ex.get_grad(ta), da, "d alpha_loss_outside / d raw");
  auto dd = ref_order_grad(depth, mask, N, kRows);
  for (double& x : dd) x *= w[3];
  expect_grad_close(ex.get_grad(tdp), dd, "d order_loss / d depth");
}

// render.cl with the reference code's options (RenderOptions: blend epsilon 1e-8, alpha_full
// as a sum, nerf_depth; and plain compositing), 1009 rays. Tolerances as the render case.
BOOST_AUTO_TEST_CASE(render_reference_options) {
  RenderRefInput in = random_render_case(2, static_cast<int>(kRows), 4, 5, false, true, 161);
  in.blend_eps = 1e-8;
  in.alpha_full_sum = true;
  in.nerf_depth = true;
  RenderTargets t = random_targets(in, 162);
  DeviceRender d = run_device_render(in, t);
  expect_forward_close(d, in, 2e-6, 1e-5, "render, reference options");
  expect_gradient_close(d, in, t, 1e-4, 1e-3, "render, reference options");
  RenderRefInput plain = random_render_case(1, static_cast<int>(kRows), 4, 5, false, true, 163);
  plain.no_blend = true;
  t = random_targets(plain, 164);
  d = run_device_render(plain, t);
  expect_forward_close(d, plain, 2e-6, 1e-5, "render, plain");
  expect_gradient_close(d, plain, t, 1e-4, 1e-3, "render, plain");
}

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

// render.cl: render_forward / render_backward, one work-item per ray, 1009 rays x 4 samples
// of 2 NeRFs with density noise. Tolerances as test_render: forward atol 2e-6 rtol 1e-5;
// gradient against float64 finite differences of the reference, rtol 1e-3, atol 1e-4 of the
// gradient scale.
BOOST_AUTO_TEST_CASE(render) {
  rt();
  const RenderRefInput in = random_render_case(2, static_cast<int>(kRows), 4, 5, false, true, 151);
  const RenderTargets t = random_targets(in, 152);
  const DeviceRender d = run_device_render(in, t);
  expect_forward_close(d, in, 2e-6, 1e-5, "render 2 NeRFs x 1009 rays");
  expect_gradient_close(d, in, t, 1e-4, 1e-3, "render 2 NeRFs x 1009 rays");
}

// sampling.cl: rays_generate (2D: 1009 rays x 3 cameras), sample_spacing and sample_points
// (5045 samples x 3 NeRFs, groups of 1 and 2), instance_points (1009 points x 3 instances).
// Tolerances as test_rays: rays atol 1e-6 rtol 1e-6; depths atol 6e-6; spacings rtol 1e-4;
// positions atol 6e-5; instance points 1e-4.
BOOST_AUTO_TEST_CASE(sampling) {
  const std::vector<Camera> cams = {make_camera(400, 64, 48, {0, 0, 4}, 0.0, 0.0),
                                    make_camera(400, 64, 48, {0, 0, 4}, 0.2, 0.0),
                                    make_camera(350, 64, 48, {0.5, 0, 4}, -0.2, 0.1)};
  const size_t N = cams.size(), S = 5;
  const auto pixels = random_pixels(kRows, 64, 48, 161);
  const auto jitter = random_floats(kRows * S, 0, 1, 162);
  Graph g;
  Tensor tp = g.input("pixels", Shape{kRows, 2}), tc = g.input("cameras", Shape{N, 16});
  Tensor tj = g.input("jitter", Shape{kRows, S});
  Rays rays = generate_rays(tp, tc);
  SampleOptions so;
  so.samples = static_cast<int>(S);
  so.near = 2.0f;
  so.far = 6.0f;
  so.groups = {1, 2};
  Samples s = stratified_samples(rays, tj, so);
  for (Tensor x : {rays.origins, rays.directions, rays.viewdirs, s.z, s.delta, s.positions[0],
                   s.positions[1]})
    g.keep(x);
  Executor ex(rt(), g);
  ex.set(tp, pixels);
  ex.set(tc, camera_rows(cams));
  ex.set(tj, jitter);
  ex.forward();
  const auto o = ex.get(rays.origins), dir = ex.get(rays.directions), view = ex.get(rays.viewdirs);
  std::vector<double> o_ref, d_ref, v_ref;
  for (const Camera& c : cams)
    for (size_t r = 0; r < kRows; ++r) {
      const RefRay ref = ref_ray(c, pixels[2 * r], pixels[2 * r + 1], false, 1.0);
      o_ref.insert(o_ref.end(), ref.o.begin(), ref.o.end());
      d_ref.insert(d_ref.end(), ref.d.begin(), ref.d.end());
      v_ref.insert(v_ref.end(), ref.view.begin(), ref.view.end());
    }
  expect_close(o, o_ref, 1e-6, 1e-6, "origins");
  expect_close(dir, d_ref, 1e-6, 1e-6, "directions");
  expect_close(view, v_ref, 1e-6, 1e-6, "viewdirs");
  const auto z = ref_depths(kRows, S, 2.0, 6.0, jitter);
  expect_close(ex.get(s.z), z, 6e-6, 1e-6, "z");
  std::vector<double> delta, pos0, pos1;
  for (size_t n = 0; n < N; ++n)
    for (size_t r = 0; r < kRows; ++r) {
      const float* d = &dir[(n * kRows + r) * 3];
      const double norm = std::sqrt(double(d[0]) * d[0] + double(d[1]) * d[1] + double(d[2]) * d[2]);
      for (size_t i = 0; i < S; ++i) {
        const double zi = z[r * S + i];
        delta.push_back((i + 1 < S ? z[r * S + i + 1] - zi : 1e10) * norm);
        for (int k = 0; k < 3; ++k) (n == 0 ? pos0 : pos1).push_back(o[(n * kRows + r) * 3 + k] + zi * d[k]);
      }
    }
  expect_close(ex.get(s.delta), delta, 1e-6, 1e-4, "delta");
  expect_close(ex.get(s.positions[0]), pos0, 6e-5, 1e-6, "positions of group 0");
  expect_close(ex.get(s.positions[1]), pos1, 6e-5, 1e-6, "positions of group 1");

  // instance_points: kRows points, 3 placed instances, as test_rays.
  check_instance_points(rt(), kRows, 163);
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

// depth_loss.cl: depth_loss_forward / _backward (one work-item each, looping over 1009 rays,
// every fifth invalid). The float64 reference is test_depth_loss_op.cpp's definition; the
// gradient is checked element by element against its central differences (h = 1e-6, exact to
// ~1e-9). Tolerances: the loss is a float32 sum over 1009 rays, rtol 1e-4 as
// test_depth_loss_op; its gradient carries the cancellations of the standardisation, rtol 1e-3
// and atol 1e-4 of the gradient's scale.
BOOST_AUTO_TEST_CASE(depth_loss_kernels) {
  const auto p = random_floats(kRows, 0.0f, 1.0f, 181), t = random_floats(kRows, -2.0f, 3.0f, 182);
  std::vector<float> w(kRows, 1.0f);
  for (size_t i = 0; i < kRows; i += 5) w[i] = 0.0f;
  const auto reference = [&](const std::vector<double>& d) {
    double n = 0, sp = 0, st = 0;
    for (size_t r = 0; r < kRows; ++r) n += w[r], sp += w[r] * d[r], st += w[r] * t[r];
    const double mp = sp / n, mt = st / n;
    double vp = 0, vt = 0;
    for (size_t r = 0; r < kRows; ++r)
      vp += w[r] * (d[r] - mp) * (d[r] - mp), vt += w[r] * (t[r] - mt) * (t[r] - mt);
    const double sdp = std::sqrt(vp / n + 1e-6), sdt = std::sqrt(vt / n + 1e-6);
    double sum = 0;
    for (size_t r = 0; r < kRows; ++r) {
      const double e = (d[r] - mp) / sdp - (t[r] - mt) / sdt;
      sum += w[r] * e * e;
    }
    return sum / n;
  };
  Graph g;
  const Shape s{kRows};
  Tensor tp = g.input("depth", s, true), tt = g.input("target", s), tw = g.input("valid", s);
  g.set_loss(depth_loss(tp, tt, tw));
  Executor ex(rt(), g);
  ex.set(tp, p);
  ex.set(tt, t);
  ex.set(tw, w);
  ex.forward();
  ex.backward();
  std::vector<double> d = to_double(p);
  expect_close({ex.loss()}, {reference(d)}, 0, 1e-4, "depth_loss");
  std::vector<double> fd(kRows);
  for (size_t r = 0; r < kRows; ++r) {
    const double x0 = d[r], h = 1e-6;
    d[r] = x0 + h;
    const double lp = reference(d);
    d[r] = x0 - h;
    const double lm = reference(d);
    d[r] = x0;
    fd[r] = (lp - lm) / (2 * h);
  }
  expect_close(ex.get_grad(tp), fd, 1e-4 * max_abs(fd), 1e-3, "d depth_loss / d depth");

  // free_space.cl: free_space_fit / _partial / _backward, 2 NeRFs x 1009 rays x 3 samples,
  // against the float64 reference and its central differences
  // (tests/test_free_space_loss_op.cpp states the tolerances).
  FreeSpaceCase f;
  f.N = 2, f.R = kRows, f.S = 3;
  f.raw = random_floats(f.N * kRows * f.S * f.C, -1, 1, 183);
  for (size_t e = 0; e < f.N * kRows * f.S; ++e) f.raw[e * f.C + 3] = 0.3f + std::fabs(f.raw[e * f.C + 3]) * 3;
  f.delta = random_floats(f.N * kRows * f.S, 0.1f, 0.4f, 184);
  for (size_t r = 0; r < kRows; ++r)
    for (size_t i = 0; i < f.S; ++i) f.z.push_back(0.2f + 0.3f * i);
  f.depth = p;
  f.target = t;
  f.valid = w;
  f.masks = random_floats(f.N * kRows, 0, 1, 185);
  for (float& m : f.masks) m = m < 0.3f ? 0.0f : 1.0f;
  f.behind = 0.5f;  // both sides of the surface
  const FreeSpaceRun run = run_free_space(f, rt());
  expect_close({run.loss}, {free_space_reference(f, f.raw)}, 0, 1e-4, "free_space_loss");
  const std::vector<double> ffd = free_space_sigma_fd(f, 1e-3f);
  expect_close(run.d_raw, ffd, 1e-5 * max_abs(ffd), 1e-3, "d free_space_loss / d raw");
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

// The sweep above covers every kernel of every embedded family (parsed from the sources).
BOOST_AUTO_TEST_CASE(every_kernel_ran_at_an_odd_size,
                     *utf::depends_on("odd_sizes/encoding") *
                         utf::depends_on("odd_sizes/activation_and_reduce") *
                         utf::depends_on("odd_sizes/tensor_copies") *
                         utf::depends_on("odd_sizes/losses") *
                         utf::depends_on("odd_sizes/optimiser") *
                         utf::depends_on("odd_sizes/render") *
                         utf::depends_on("odd_sizes/reference_losses") *
                         utf::depends_on("odd_sizes/render_reference_options") *
                         utf::depends_on("odd_sizes/sampling") *
                         utf::depends_on("odd_sizes/own_gemm_kernels") *
                         utf::depends_on("odd_sizes/depth_loss_kernels") *
                         utf::depends_on("odd_sizes/termination_kernels")) {
  std::map<std::pair<std::string, std::string>, std::vector<LaunchRecord>> by_kernel;
  for (const LaunchRecord& r : rt().launches()) by_kernel[{r.family, r.name}].push_back(r);
  size_t kernels = 0;
  for (const KernelSource& src : kernel_sources()) {
    const std::string family(src.family);
    if (src.family == kKernelPrelude) continue;  // helpers only, compiled into every family
    if (kCoveredElsewhere.count(family)) {
      BOOST_TEST_MESSAGE(family << ": covered by " << kCoveredElsewhere.at(family));
      continue;
    }
    const auto names = kernel_names(src.source);
    BOOST_TEST(!names.empty(), "no kernel found in kernels/" << family << ".cl");
    for (const std::string& name : names) {
      ++kernels;
      const auto it = by_kernel.find({family, name});
      const bool launched = it != by_kernel.end();
      const bool odd = launched && std::any_of(it->second.begin(), it->second.end(), ragged);
      BOOST_TEST(odd, "kernel " << name << " of kernels/" << family << ".cl was "
                                << (launched ? "launched only at sizes that fill whole work-groups"
                                             : "never launched")
                                << " by the odd_sizes sweep: add it to tests/test_odd_sizes.cpp");
      if (odd)
        for (const LaunchRecord& r : it->second)
          if (ragged(r)) {
            BOOST_TEST_MESSAGE(family << "/" << name << ": size " << r.size[0]
                                      << (r.dims > 1 ? " x " + std::to_string(r.size[1]) : "")
                                      << ", work-group " << r.local[0]
                                      << (r.dims > 1 ? " x " + std::to_string(r.local[1]) : ""));
            break;
          }
    }
  }
  BOOST_TEST(kernels >= 25u, "only " << kernels << " kernels parsed from the embedded sources");
}

BOOST_AUTO_TEST_SUITE_END()

// The dense op, y = act(x w + b) with the bias and activation fused into the GEMM's store
// (gemm.hpp's epilogue), against a float64 host reference for every activation and under each
// kind of tuned forward GEMM: the blocked kernel, the blocked kernel with a split reduction
// (the epilogue after gemm_reduce's sum), the first own kernel (gemm_nn) and CLBlast (no
// fusion: a bias_act pass). Sizes are odd (M, N, K no multiple of a tile, a work-group or a
// split chunk), with several networks batched and with fewer live rows than the capacity.
// The fused results are compared with the two-op path bias_act(linear(x, w), b, act), forward
// and gradients, and the gradients with central differences.
//
// Tolerances:
// - forward against float64: per element |y - ref| <= 2 (K + 1) u (sum_l |x_il w_lj| + |b_j|)
//   + 16 u |ref| + 1e-30, u = 2^-24: the float32 dot product of length K plus the bias
//   (Higham's bound, doubled as test_gemm's), carried through an activation whose slope is at
//   most 1, plus the activation's own error (OpenCL's full profile: exp 3 ulp, log1p 2 ulp,
//   divide 2.5 ulp, together <= 8 ulp <= 16 u |ref|). A wrong index or a missing bias moves
//   results by O(1) and fails.
// - fused against two-op: the same products summed in the same order and the bias added in
//   the same rounding, so equal except for the activation's exp/log1p/division, which the
//   blocked kernel's float8 store may evaluate through another vector routine than
//   bias_act's pass: each within OpenCL's full-profile bounds (exp 3 ulp, log1p 2 ulp, divide
//   2.5 ulp) of the exact value, so the two within twice that, 8 ulp <= 16 u |y|. Gradients
//   come from the same kernels on those y: 16 u of the largest gradient. Measured on PoCL:
//   identity and ReLU bit-equal everywhere, sigmoid and softplus bit-equal except under the
//   blocked kernel's float8 store (~0.4% of elements, <= 2.8 u |y|), the gradients then
//   within 2.3 u of their largest. A layout or bias error is O(1) and fails.
// - fused against two-op under the host BLAS: each row block of the fused path is its own BLAS
//   call, which may sum in another order than the one call of the two-op path
//   (host_blas_row_blocks), so y within the sum of the two paths' forward bounds; the
//   gradients as above. Measured under OpenBLAS's Haswell kernels: 0.7-1.5% of y differ, by at
//   most 0.031 of that bound, the gradients within 3 u of their largest.
// - finite differences: the harness default (2e-2 of the gradient's scale), pre-activations
//   kept 0.05 from ReLU's kink (the stencil moves them by at most 1e-2).
#include <boost/test/unit_test.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>

#include <unistd.h>

#include "harness.hpp"
#include "nova/graph/executor.hpp"
#include "nova/ops/linalg/gemm.hpp"
#include "nova/ops/linalg/dense.hpp"
#include "nova/loss/terms.hpp"

using namespace nova;
using nova::test::random_floats;

namespace {

namespace fs = std::filesystem;

const Activation kActivations[] = {Activation::Identity, Activation::ReLU, Activation::Sigmoid,
                                   Activation::Softplus};
const double u = std::numeric_limits<float>::epsilon() / 2;

struct Case {
  size_t batch, m, k, n;
  size_t live;  // rows in use per network (== m: static)
};

// Feeds x to the layer with `live` of its `m` rows in use, as packed samples do: the live rows
// of every network laid out densely ([B, live, K]) at the start of the tensor.
class LiveRows final : public Op {
 public:
  LiveRows(int extent, size_t live) : extent_(extent), live_(live) {}
  std::string type() const override { return "live_rows"; }
  void forward(ExecContext& ctx) override {
    ctx.set_extent(extent_, live_);
    const Shape& s = ctx.in_shape(0);
    const size_t bytes = s.numel() / s[s.row_dim()] * live_ * sizeof(float);
    cl_check(clEnqueueCopyBuffer(ctx.rt.queue(), ctx.in(0), ctx.out(0), 0, 0, bytes, 0,
                                 nullptr, nullptr),
             "clEnqueueCopyBuffer(live rows)");
  }
  void backward(ExecContext&) override {}  // x needs no gradient here

 private:
  int extent_;
  size_t live_;
};

struct Layer {
  std::vector<float> x, w, b, target;
};

Layer random_layer(const Case& c, unsigned seed) {
  return {random_floats(c.batch * c.m * c.k, -1, 1, seed),
          random_floats(c.batch * c.k * c.n, -1, 1, seed + 1),
          random_floats(c.batch * c.n, -1, 1, seed + 2),
          random_floats(c.batch * c.m * c.n, -1, 1, seed + 3)};
}

struct Result {
  std::vector<float> y, dw, db;  // y: the live rows, [B, live, N]
};

// One forward and backward of the layer, fused (dense) or as the two ops.
Result run_layer(const Case& c, Activation act, bool fused, const Layer& in) {
  Graph g;
  const auto shape = [&](size_t rows, size_t cols) {
    return c.batch > 1 ? Shape{c.batch, rows, cols} : Shape{rows, cols};
  };
  const Tensor xin = g.input("x", shape(c.m, c.k));
  Tensor x = xin;
  Tensor w = g.input("w", c.batch > 1 ? Shape{c.batch, c.k, c.n} : Shape{c.k, c.n}, true);
  Tensor b = g.input("b", c.batch > 1 ? Shape{c.batch, c.n} : Shape{c.n}, true);
  if (c.live != c.m) {
    const int e = g.add_extent("live", c.m);
    Tensor xl = g.activation("x.live", x.shape());
    g.bind_extent(xl, e);
    g.add(std::make_unique<LiveRows>(e, c.live), {xin}, {xl});
    x = xl;
  }
  Tensor y = fused ? dense(x, w, b, act) : bias_act(linear(x, w), b, act);
  Tensor target = g.input("target", y.shape());
  g.keep(y);
  // The loss reads every row, the dead ones too; their gradients are never read by the layer.
  g.set_loss(mse(y, target));
  Executor ex(test::runtime(), g);
  ex.set(xin, in.x);
  ex.set(w, in.w);
  ex.set(b, in.b);
  ex.set(target, in.target);
  ex.forward();
  ex.backward();
  Result r{ex.get(y), ex.get_grad(w), ex.get_grad(b)};
  if (c.live != c.m) {  // keep the live rows of every network
    std::vector<float> live;
    for (size_t p = 0; p < c.batch; ++p)
      live.insert(live.end(), r.y.begin() + p * c.live * c.n,
                  r.y.begin() + (p * c.live + c.live) * c.n);
    r.y = live;
  }
  return r;
}

// The float64 reference of every live element and its forward bound (the header's).
struct Reference {
  std::vector<double> y, bound;
};

Reference forward_reference(const Case& c, Activation act, const Layer& in) {
  Reference r;
  for (size_t p = 0; p < c.batch; ++p)
    for (size_t i = 0; i < c.live; ++i)
      for (size_t j = 0; j < c.n; ++j) {
        const double bias = in.b[p * c.n + j];
        double h = bias, mag = std::fabs(bias);
        for (size_t l = 0; l < c.k; ++l) {
          const double t = double(in.x[(p * c.live + i) * c.k + l]) * in.w[(p * c.k + l) * c.n + j];
          h += t;
          mag += std::fabs(t);
        }
        const double ref = test::activation_reference(act, h);
        r.y.push_back(ref);
        r.bound.push_back(2 * (c.k + 1) * u * mag + 16 * u * std::fabs(ref) + 1e-30);
      }
  return r;
}

// Forward against float64 (the bound in the header) over the live rows.
void check_forward(const Reference& ref, Activation act, const std::vector<float>& y) {
  double worst = 0;
  size_t worst_i = 0;
  for (size_t at = 0; at < ref.y.size(); ++at) {
    const double e = std::fabs(y[at] - ref.y[at]) / ref.bound[at];
    if (!(e <= worst)) worst = std::isnan(e) ? INFINITY : e, worst_i = at;
  }
  BOOST_TEST(worst <= 1.0, activation_name(act) << ": element " << worst_i << " is "
                                                << y[worst_i] << ", error/bound " << worst);
}

// Two results that each meet the forward bound: apart by at most the sum of their bounds.
void expect_within_forward_bounds(const Reference& ref, const std::vector<float>& a, const std::vector<float>& b,
                                  const std::string& what) {
  BOOST_REQUIRE_EQUAL(a.size(), b.size());
  double worst = 0;
  size_t worst_i = 0, differ = 0;
  for (size_t at = 0; at < a.size(); ++at) {
    differ += a[at] != b[at];
    const double e = std::fabs(double(a[at]) - b[at]) / (2 * ref.bound[at]);
    if (!(e <= worst)) worst = std::isnan(e) ? INFINITY : e, worst_i = at;
  }
  BOOST_TEST_MESSAGE(what << ": " << differ << " of " << a.size() << " elements differ, by " << worst
                          << " of twice the forward bound at most");
  BOOST_TEST(worst <= 1.0, what << ": element " << worst_i << " is " << a[worst_i] << " against " << b[worst_i]);
}

// |a - b| <= 16 u of the larger magnitude per element, or of `scale` (the header).
void expect_ulps(const std::vector<float>& a, const std::vector<float>& b, double scale,
                 const std::string& what) {
  BOOST_REQUIRE_EQUAL(a.size(), b.size());
  size_t differ = 0, worst_i = 0;
  double worst = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    if (a[i] == b[i]) continue;
    ++differ;
    const double mag = scale > 0 ? scale : std::max(std::fabs(a[i]), std::fabs(b[i]));
    const double e = std::fabs(double(a[i]) - b[i]) / (16 * u * mag);
    if (!(e <= worst)) worst = std::isnan(e) ? INFINITY : e, worst_i = i;
  }
  BOOST_TEST_MESSAGE(what << ": " << differ << " of " << a.size() << " elements differ, by "
                          << worst * 16 << " u of the magnitude at most");
  BOOST_TEST(worst <= 1.0, what << ": element " << worst_i << " is " << a[worst_i] << " against "
                                << b[worst_i] << " (" << worst * 16 << " u of the magnitude)");
}

double max_abs(const std::vector<float>& v) {
  double m = 0;
  for (float x : v) m = std::max(m, double(std::fabs(x)));
  return m;
}

// Makes `config` the tuned forward GEMM for the layer's shape class (through a cache file of
// this test's own) and restores the user's cache and provider when it goes.
class ForcedForward {
 public:
  ForcedForward(const Case& c, const std::string& config)
      : path_((fs::temp_directory_path() / ("nova-test-dense-" + std::to_string(::getpid())) /
               "gemm-tuning.tsv").string()),
        provider_(gemm_provider(test::runtime())) {
    Runtime& rt = test::runtime();
    GemmCacheEntry e = gemm_cache_key(rt.info());
    const GemmArgs g{false, false, c.live, c.n, c.k};
    e.shape = *gemm_shape_class(g);
    e.config = GemmConfig::parse(config);
    e.default_gflops = e.tuned_gflops = 1;
    write_gemm_cache(path_, {e});
    BOOST_REQUIRE(reload_gemm_cache(rt, path_) == 1u);
    set_gemm_provider(rt, GemmProvider::Tuned);
    BOOST_REQUIRE(gemm_choice(rt, g) == e.config);
  }
  ~ForcedForward() {
    Runtime& rt = test::runtime();
    set_gemm_provider(rt, provider_);
    try {
      reload_gemm_cache(rt);  // back to the user's cache
    } catch (const Error&) {
    }
    fs::remove_all(fs::path(path_).parent_path());
  }

 private:
  std::string path_;
  GemmProvider provider_;
};

// Every activation under `config`: fused against float64 and against the two ops. With
// `same_sums` false (the host BLAS) the fused products need not be summed in the two-op
// path's order: y is then held to both paths' forward bounds instead of to 16 u |y|.
void check_config(const Case& c, const std::string& config, unsigned seed, bool same_sums = true) {
  ForcedForward forced(c, config);
  const Layer in = random_layer(c, seed);
  for (Activation act : kActivations) {
    BOOST_TEST_CONTEXT(config << ", " << activation_name(act) << ", batch " << c.batch << ", "
                              << c.live << " of " << c.m << " rows x " << c.k << " -> " << c.n) {
      const Result fused = run_layer(c, act, true, in);
      const Result two = run_layer(c, act, false, in);
      const Reference ref = forward_reference(c, act, in);
      check_forward(ref, act, fused.y);
      if (same_sums) {
        expect_ulps(fused.y, two.y, 0, "y fused vs two ops");
      } else {
        check_forward(ref, act, two.y);
        expect_within_forward_bounds(ref, fused.y, two.y, "y fused vs two ops");
      }
      expect_ulps(fused.dw, two.dw, max_abs(two.dw), "dw fused vs two ops");
      expect_ulps(fused.db, two.db, max_abs(two.db), "db fused vs two ops");
    }
  }
}

// The tuned mode needs at least kGemmTunedMinRows rows: 2053 (prime) live rows.
constexpr size_t kRows = 2053;

}  // namespace

BOOST_AUTO_TEST_SUITE(dense)

BOOST_AUTO_TEST_CASE(blocked_kernel) {
  check_config({1, kRows, 29, 37, kRows}, "blocked RM=6 VN=2", 11);
  check_config({3, kRows, 29, 37, kRows}, "blocked RM=4 VN=1", 21);
}

// K = 29 in chunks of 8 (the last one 5): four partial sums, the epilogue on their sum.
BOOST_AUTO_TEST_CASE(blocked_kernel_split_reduction) {
  check_config({1, kRows, 29, 37, kRows}, "blocked RM=6 VN=2 KC=8", 31);
  check_config({2, kRows, 29, 37, kRows}, "blocked RM=5 VN=1 KC=8", 41);
}

BOOST_AUTO_TEST_CASE(first_own_kernel) {
  check_config({2, kRows, 29, 37, kRows}, "kernels", 51);
}

// CLBlast does not fuse: the dense op runs it and a bias_act pass, with the same results.
BOOST_AUTO_TEST_CASE(clblast_two_passes) {
  check_config({2, kRows, 29, 37, kRows}, "clblast", 61);
}

// Packed samples: 2053 of 4099 rows per network in use; the dense op runs only those.
BOOST_AUTO_TEST_CASE(live_rows_below_capacity) {
  for (const char* config : {"blocked RM=6 VN=2", "blocked RM=4 VN=2 KC=8", "clblast"})
    check_config({3, 4099, 29, 37, kRows}, config, 71);
}

// The host BLAS (a CPU device with native kernels) applies the identity and ReLU epilogues
// itself, in row blocks of 8,192 rows at 256 columns: 16411 live rows (of 17011) are two full
// blocks and a ragged one, two networks batched. Each block is its own BLAS call, whose
// micro-kernel tiles follow the block's rows rather than the whole product's: OpenBLAS's
// SkylakeX and Cooperlake kernels give the single call's bits, its Haswell and Zen kernels
// sum the rows near a block's edge in another order (5488 of 16411 rows of a lone 16411 x 29
// x 256 product, from row 8184 on). So y is held to the forward bound, as the two-op path is,
// rather than to the two-op path's bits.
BOOST_AUTO_TEST_CASE(host_blas_row_blocks) {
  if (!host_gemm_available(test::runtime())) {
    BOOST_TEST_MESSAGE("skipped: the device has no host BLAS provider");
    return;
  }
  check_config({2, 17011, 29, 256, 16411}, "host", 91, /*same_sums=*/false);
}

BOOST_AUTO_TEST_CASE(which_configurations_fuse_the_epilogue) {
  Runtime& rt = test::runtime();
  Buffer a = rt.upload_floats(std::vector<float>(4, 1.0f));
  const GemmArgs g{false, false, 2, 2, 1, 1.0f, a.get(), 1, 2, a.get(), 2, 2, 0.0f, a.get(), 2, 4, 1};
  const GemmEpilogue e{a.get(), 2, Activation::ReLU};
  BOOST_CHECK_THROW(gemm_with(rt, GemmConfig{}, g, nullptr, e), Error);
  BOOST_TEST(!gemm_fuses_epilogue(GemmConfig{}, g, Activation::ReLU));
  BOOST_TEST(gemm_fuses_epilogue(GemmConfig::parse("blocked RM=6 VN=2"), g, Activation::ReLU));
  BOOST_TEST(gemm_fuses_epilogue(GemmConfig::parse("kernels"), g, Activation::Sigmoid));
  // The host BLAS fuses the epilogues it computes with the device's bits (identity, ReLU).
  BOOST_TEST(gemm_fuses_epilogue(GemmConfig{"host", {}}, g, Activation::ReLU));
  BOOST_TEST(gemm_fuses_epilogue(GemmConfig{"host", {}}, g, Activation::Identity));
  BOOST_TEST(!gemm_fuses_epilogue(GemmConfig{"host", {}}, g, Activation::Sigmoid));
  GemmArgs transposed = g;
  transposed.trans_a = true;
  BOOST_TEST(!gemm_fuses_epilogue(GemmConfig{"host", {}}, transposed, Activation::ReLU));
}

// Central differences through the fused forward (NOVA_GEMM=kernels: gemm_nn with the epilogue
// at any size) and the two-pass one (CLBlast), one and two networks. Rows of x are drawn again
// until every pre-activation is 0.05 from 0 (ReLU's kink).
BOOST_AUTO_TEST_CASE(gradients) {
  Runtime& rt = test::runtime();
  const GemmProvider before = gemm_provider(rt);
  const size_t m = 13, k = 5, n = 4;
  for (GemmProvider provider : {GemmProvider::Kernels, GemmProvider::CLBlast})
    for (Activation act : kActivations)
      for (size_t batch : {size_t{1}, size_t{2}}) {
        set_gemm_provider(rt, provider);
        const auto w = random_floats(batch * k * n, -1, 1, 81);
        const auto b = random_floats(batch * n, -0.5f, 0.5f, 82);
        std::vector<float> x(batch * m * k);
        unsigned seed = 83;
        for (size_t p = 0; p < batch; ++p)
          for (size_t i = 0; i < m; ++i)
            for (bool clear = false; !clear; ++seed) {
              const auto row = random_floats(k, -1, 1, seed);
              clear = true;
              for (size_t j = 0; j < n; ++j) {
                double h = b[p * n + j];
                for (size_t l = 0; l < k; ++l) h += double(row[l]) * w[(p * k + l) * n + j];
                clear = clear && std::fabs(h) >= 0.05;
              }
              std::copy(row.begin(), row.end(), x.begin() + (p * m + i) * k);
            }
        BOOST_TEST_CONTEXT(gemm_provider_name(provider) << ", " << activation_name(act)
                                                         << ", batch " << batch) {
          test::check_gradients(
              [&](Graph& g) {
                const bool batched = batch > 1;
                Tensor tx = g.input("x", batched ? Shape{batch, m, k} : Shape{m, k}, true);
                Tensor tw = g.input("w", batched ? Shape{batch, k, n} : Shape{k, n}, true);
                Tensor tb = g.input("b", batched ? Shape{batch, n} : Shape{n}, true);
                return test::OpUnderTest{{tx, tw, tb}, nova::dense(tx, tw, tb, act)};
              },
              {x, w, b});
        }
      }
  set_gemm_provider(rt, before);
}

// bias_act's backward on the host, walking rows in order in a kernel (CPUs) and strided (GPUs)
// sum the same partials in the same order: dh and db equal bit for bit, for every activation
// (the host walk takes the identity and ReLU, the others fall back to the kernel's), one and
// three networks, a ragged row count, a narrow ragged width and one wide enough that the host
// walk splits its columns among threads, and dh accumulated into an input read twice.
BOOST_AUTO_TEST_CASE(host_row_walk_and_strided_bias_gradients_agree_bit_for_bit) {
  Runtime& rt = test::runtime();
  const bool native = rt.info().runs_native_calls();
  std::vector<const char*> walks = {"strided", "row-walk"};
  if (native) walks.push_back("host");
  const size_t rows = 1013;
  for (size_t cols : {size_t{9}, size_t{300}})
    for (Activation act : kActivations)
      for (size_t batch : {size_t{1}, size_t{3}}) {
        std::vector<std::vector<float>> grads[3];
        for (size_t w = 0; w < walks.size(); ++w) {
          setenv("NOVA_BIAS_GRAD", walks[w], 1);
          Graph g;
          const Shape hs = batch > 1 ? Shape{batch, rows, cols} : Shape{rows, cols};
          Tensor h = g.input("h", hs, true);
          Tensor b = g.input("b", batch > 1 ? Shape{batch, cols} : Shape{cols}, true);
          Tensor t = g.input("t", hs);
          // h feeds bias_act and the loss directly: its gradient accumulates.
          g.set_loss(weighted_sum({mse(bias_act(h, b, act), t), mse(h, t)}, {1.0f, 0.5f}));
          Executor ex(rt, g);
          ex.set(h, random_floats(hs.numel(), -3, 3, 91));
          ex.set(b, random_floats(batch * cols, -1, 1, 92));
          ex.set(t, random_floats(hs.numel(), -1, 1, 93));
          ex.forward();
          ex.backward();
          grads[w] = {ex.get_grad(h), ex.get_grad(b)};
        }
        unsetenv("NOVA_BIAS_GRAD");
        for (size_t w = 1; w < walks.size(); ++w)
          BOOST_TEST_CONTEXT(walks[w] << " against strided, " << activation_name(act) << ", "
                                      << cols << " columns, batch " << batch) {
            BOOST_TEST((grads[w][0] == grads[0][0]));
            BOOST_TEST((grads[w][1] == grads[0][1]));
          }
      }
  // A CPU device (PoCL) must run the host walk; a GPU has no native kernels and checks the two
  // device walks only.
  if (rt.info().type & CL_DEVICE_TYPE_CPU)
    BOOST_TEST(native, "the CPU test device runs no native kernels: the host walk was not checked");
  else if (!native)
    BOOST_TEST_MESSAGE("device without native kernels: the host walk is not checked here");
  setenv("NOVA_BIAS_GRAD", "sideways", 1);
  BOOST_CHECK_THROW(bias_grad_walk(rt.info()), Error);
  unsetenv("NOVA_BIAS_GRAD");
}

BOOST_AUTO_TEST_SUITE_END()

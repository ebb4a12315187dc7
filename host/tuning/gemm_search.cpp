// The GEMM parameter search behind `nova tune`: candidates per shape class (CLBlast Xgemm
// parameter sets, nova's own kernels, blocked-kernel variants), each timed on the device and
// checked against a float64 host reference before it may win. Candidates run through a
// GemmRunner: the GEMM op's own functions, which sit above this module.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>

#include "nova/tuning/gemm_tuning.hpp"

namespace nova {
namespace {

using Params = std::map<std::string, size_t>;

// CLBlast's own constraints on Xgemm parameters (its tuner's, src/tuning/kernels/xgemm.hpp),
// and the device's work-group and local-memory limits.
bool clblast_xgemm_valid(const Params& p, size_t max_wg, size_t local_bytes) {
  auto v = [&](const char* k) { return p.at(k); };
  const size_t mdimc = v("MDIMC"), ndimc = v("NDIMC"), mdima = v("MDIMA"), ndimb = v("NDIMB");
  if (v("KWG") % v("KWI")) return false;
  if (v("MWG") % (mdimc * v("VWM")) || v("NWG") % (ndimc * v("VWN"))) return false;
  if (v("MWG") % (mdima * v("VWM")) || v("NWG") % (ndimb * v("VWN"))) return false;
  if (v("KWG") % ((mdimc * ndimc) / mdima) || v("KWG") % ((mdimc * ndimc) / ndimb)) return false;
  if (mdimc * ndimc > max_wg) return false;
  const size_t local = (v("SA") * v("KWG") * v("MWG") + v("SB") * v("KWG") * v("NWG")) * 4;
  return local <= local_bytes;
}

// A small grid of Xgemm parameter sets around what works on CPUs and GPUs alike: tiles of
// 32-128, 8x8 or 16x16 threads, vectors of 4 or 8, with and without local-memory staging.
std::vector<Params> clblast_grid(Runtime& rt) {
  size_t local_bytes = 0;
  cl_ulong lb = 0;
  if (clGetDeviceInfo(rt.device(), CL_DEVICE_LOCAL_MEM_SIZE, sizeof(lb), &lb, nullptr) == CL_SUCCESS)
    local_bytes = static_cast<size_t>(lb);
  std::vector<Params> out;
  for (size_t s : {1, 0})
    for (size_t mwg : {64, 32, 128})
      for (size_t nwg : {64, 128, 32})
        for (size_t kwg : {16, 32})
          for (size_t dimc : {8, 16})
            for (size_t vw : {8, 4}) {
              Params p = {{"GEMMK", 0}, {"KREG", 1},     {"STRM", 0},     {"STRN", 0},
                          {"SA", s},    {"SB", s},       {"MWG", mwg},    {"NWG", nwg},
                          {"KWG", kwg}, {"MDIMC", dimc}, {"NDIMC", dimc}, {"MDIMA", dimc},
                          {"NDIMB", dimc}, {"KWI", 2},   {"VWM", vw},     {"VWN", vw}};
              if (clblast_xgemm_valid(p, rt.info().max_work_group_size, local_bytes))
                out.push_back(p);
            }
  return out;
}

struct HostProblem {
  GemmArgs args;  // without buffers
  std::vector<float> a, b, c0;
};

// op(A) op(B) for a shape class with the long dimension `rows`: nn X[m,k] W[k,n];
// nt dY[m,k] W[n,k]^T; tn X[k,m]^T dY[k,n].
HostProblem make_problem(const GemmShapeClass& s, size_t rows, float beta, unsigned seed) {
  HostProblem p;
  GemmArgs& g = p.args;
  g.trans_a = s.kind == "tn";
  g.trans_b = s.kind == "nt";
  g.m = g.trans_a ? s.m : rows;
  g.n = s.n;
  g.k = g.trans_a ? rows : s.k;
  g.lda = g.trans_a ? g.m : g.k;
  g.ldb = g.trans_b ? g.k : g.n;
  g.ldc = g.n;
  g.stride_a = g.m * g.k;
  g.stride_b = g.k * g.n;
  g.stride_c = g.m * g.n;
  g.alpha = 1.0f;
  g.beta = beta;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  p.a.resize(g.m * g.k);
  p.b.resize(g.k * g.n);
  p.c0.resize(g.m * g.n);
  for (auto* v : {&p.a, &p.b, &p.c0})
    for (float& x : *v) x = u(rng);
  return p;
}

}  // namespace

double gemm_error_ratio(const GemmArgs& g, const std::vector<float>& a,
                        const std::vector<float>& b, const std::vector<float>& c0,
                        const std::vector<float>& got, const std::vector<size_t>& rows) {
  const double u = std::numeric_limits<float>::epsilon() / 2;
  std::vector<size_t> all;
  if (rows.empty())
    for (size_t i = 0; i < g.m; ++i) all.push_back(i);
  const auto& which = rows.empty() ? all : rows;
  double worst = 0;
  std::vector<double> ref(g.n), mag(g.n);
  for (size_t i : which) {
    std::fill(ref.begin(), ref.end(), 0.0);
    std::fill(mag.begin(), mag.end(), 0.0);
    for (size_t l = 0; l < g.k; ++l) {
      const double x = g.trans_a ? a[l * g.lda + i] : a[i * g.lda + l];
      for (size_t j = 0; j < g.n; ++j) {
        const double y = g.trans_b ? b[j * g.ldb + l] : b[l * g.ldb + j];
        ref[j] += x * y;
        mag[j] += std::fabs(x * y);
      }
    }
    for (size_t j = 0; j < g.n; ++j) {
      const double cprev = g.beta == 0.0f ? 0.0 : double(c0[i * g.ldc + j]);
      const double want = double(g.alpha) * ref[j] + double(g.beta) * cprev;
      const double bound = 2.0 * g.k * u * std::fabs(g.alpha) * mag[j] +
                           2.0 * u * std::fabs(g.beta * cprev) + 1e-30;
      const double err = std::fabs(double(got[i * g.ldc + j]) - want);
      worst = std::max(worst, std::isfinite(got[i * g.ldc + j]) ? err / bound
                                                                : std::numeric_limits<double>::infinity());
    }
  }
  return worst;
}

std::vector<GemmCandidate> gemm_candidates(Runtime& rt, const GemmShapeClass& shape, bool quick,
                                           bool host_blas) {
  std::vector<GemmCandidate> c;
  c.push_back({GemmConfig{}, {}});  // the table's CLBlast: the default, always first
  // CLBlast: every compiled parameter set costs 10-35 s on PoCL with a cold cache, so only a
  // few, spread over the valid grid (the table's own set left out).
  const auto grid = clblast_grid(rt);
  const size_t want = quick ? 1 : 3;
  const auto& table = device_tuning(rt.info()).xgemm;
  auto is_table = [&](const Params& p) {
    if (!table) return false;
    for (const auto& [k, v] : table->params())
      if (!p.count(k) || p.at(k) != v) return false;
    return true;
  };
  const size_t step = std::max<size_t>(1, grid.size() / want);
  size_t taken = 0;
  for (size_t start = 0; start < step && taken < want; ++start)
    for (size_t i = start; i < grid.size() && taken < want; i += step)
      if (!is_table(grid[i])) {
        c.push_back({GemmConfig{"clblast", grid[i]}, {}});
        ++taken;
      }
  // The weight gradient through the table's CLBlast in chunks of k (split-K), for GPUs whose
  // work-groups the unsplit product leaves idle.
  if (shape.kind == "tn")
    for (size_t kc : {size_t{2048}, size_t{8192}})
      if (kc < shape.k) c.push_back({GemmConfig{"clblast", {{"KC", kc}}}, {}});
  c.push_back({GemmConfig{"kernels", {}}, {}});
  if (host_blas) c.push_back({GemmConfig{"host", {}}, {}});
  // Blocked kernels: RM x 8 VN accumulators fit 16 AVX2 / 32 AVX-512 registers up to 12.
  std::vector<std::pair<size_t, size_t>> blocks =
      quick ? std::vector<std::pair<size_t, size_t>>{{6, 2}, {4, 2}}
            : std::vector<std::pair<size_t, size_t>>{{6, 2}, {4, 2}, {8, 1}, {4, 3}, {12, 1}};
  // The weight gradient (tn) reduces over the samples: split in KC chunks, with A^T packed
  // first (TA=1: rows contiguous, as nn) or read in place (TA=0: two streams strided by a row).
  std::vector<std::pair<size_t, size_t>> splits = {{0, 0}};  // (KC, TA)
  if (shape.kind == "tn")
    splits = quick ? std::vector<std::pair<size_t, size_t>>{{256, 1}, {1024, 1}, {256, 0}}
                   : std::vector<std::pair<size_t, size_t>>{{256, 1}, {1024, 1}, {4096, 1},
                                                            {256, 0}, {1024, 0}};
  for (const auto& [rm, vn] : blocks)
    for (const auto& [kc, ta] : splits) {
      Params p = {{"RM", rm}, {"VN", vn}};
      if (kc) p["KC"] = kc;
      if (ta) p["TA"] = ta;
      c.push_back({GemmConfig{"blocked", p}, {}});
    }
  return c;
}

GemmSearchResult search_gemm(Runtime& rt, const GemmShapeClass& shape,
                             const std::vector<GemmCandidate>& candidates,
                             const GemmRunner& runner, const GemmSearchOptions& o) {
  using clock = std::chrono::steady_clock;
  const auto start = clock::now();
  GemmSearchResult res;
  res.shape = shape;
  const size_t long_dim = shape.kind == "tn" ? shape.k : shape.m;
  // The full check: a ragged long dimension, beta != 0. The timed problem: beta = 0.
  HostProblem chk = make_problem(shape, std::min(o.check_rows, long_dim), 0.5f, 11);
  HostProblem big = make_problem(shape, long_dim, 0.0f, 12);
  auto upload = [&](HostProblem& p, Buffer& a, Buffer& b, Buffer& c) {
    a = rt.upload_floats(p.a);
    b = rt.upload_floats(p.b);
    c = rt.upload_floats(p.c0);
    p.args.a = a.get();
    p.args.b = b.get();
    p.args.c = c.get();
  };
  Buffer ca, cb, cc, ba, bb, bc;
  upload(chk, ca, cb, cc);
  upload(big, ba, bb, bc);
  // Rows of the timed product checked against the reference: both ends and a spread.
  std::vector<size_t> rows;
  for (size_t i = 0; i < 8; ++i) rows.push_back(i * (big.args.m - 1) / 7);
  const double flops = 2.0 * big.args.m * big.args.n * big.args.k;

  for (size_t ci = 0; ci < candidates.size(); ++ci) {
    const GemmCandidate& cand = candidates[ci];
    GemmTrial t;
    t.label = cand.label();
    const double spent = std::chrono::duration<double>(clock::now() - start).count();
    if (ci > 0 && spent > o.max_seconds) {
      t.note = "skipped: time budget spent";
      res.trials.push_back(t);
      continue;
    }
    auto run = [&](const GemmArgs& g, cl_mem temp) {
      if (cand.custom) cand.custom(rt, g, temp);
      else runner.run(rt, cand.config, g, temp);
    };
    try {
      // 1. The full float64 check at the short long dimension.
      rt.upload(chk.args.c, chk.c0.data(), chk.c0.size() * sizeof(float));
      {
        Buffer temp;
        if (size_t bytes = cand.custom ? 0 : runner.temp_bytes(rt, cand.config, chk.args))
          temp = rt.alloc(bytes);
        run(chk.args, temp.get());
      }
      const auto got = rt.download_floats(chk.args.c, chk.c0.size());
      t.error_ratio = gemm_error_ratio(chk.args, chk.a, chk.b, chk.c0, got);
      if (!(t.error_ratio <= 1.0)) {
        std::ostringstream s;
        s << "rejected: error " << t.error_ratio << "x the float64 bound";
        t.note = s.str();
      } else {
        // 2. Timing at the full size, then sampled rows of that product.
        Buffer temp;
        if (size_t bytes = cand.custom ? 0 : runner.temp_bytes(rt, cand.config, big.args))
          temp = rt.alloc(bytes);
        std::vector<double> times;
        for (int r = 0; r <= o.repeats; ++r) {  // r = 0 warms up (and compiles)
          const auto a = clock::now();
          run(big.args, temp.get());
          rt.finish();
          if (r > 0) times.push_back(std::chrono::duration<double>(clock::now() - a).count());
        }
        std::sort(times.begin(), times.end());
        const double secs = times[times.size() / 2];
        const auto out = rt.download_floats(big.args.c, big.c0.size());
        const double e = gemm_error_ratio(big.args, big.a, big.b, big.c0, out, rows);
        t.error_ratio = std::max(t.error_ratio, e);
        if (!(e <= 1.0)) {
          std::ostringstream s;
          s << "rejected: error " << e << "x the float64 bound at full size";
          t.note = s.str();
        } else {
          t.ok = true;
          t.gflops = flops / secs * 1e-9;
        }
      }
    } catch (const Error& e) {
      t.note = std::string("failed: ") + e.what();
    }
    if (o.progress) {
      std::ostringstream s;
      s << "  " << shape.str() << "  " << t.label << ": ";
      if (t.ok) s.precision(1), s << std::fixed << t.gflops << " GFLOP/s";
      else s << t.note;
      o.progress(s.str());
    }
    res.trials.push_back(t);
    if (t.ok && (res.winner < 0 || t.gflops > res.trials[res.winner].gflops))
      res.winner = static_cast<int>(ci);
  }
  if (!res.trials.empty() && res.trials[0].ok) res.default_gflops = res.trials[0].gflops;
  if (res.winner >= 0) {
    res.config = candidates[res.winner].config;
    res.tuned_gflops = res.trials[res.winner].gflops;
  }
  return res;
}

}  // namespace nova

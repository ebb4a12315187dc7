// The GEMM op: nova's first own kernels and the register-blocked kernel (kernels/gemm.cl),
// and the dispatch among the providers (these, gemm_clblast.cpp, gemm_host.cpp) by the tuning
// cache (gemm_tuning.hpp).
#include "nova/ops/linalg/gemm.hpp"

#include <algorithm>
#include <cstdlib>
#include <map>
#include <mutex>

#include "ops/linalg/gemm_clblast.hpp"
#include "ops/linalg/gemm_host.hpp"
#include "ops/linalg/layer_parts.hpp"
#include "nova/tuning/tuning.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

std::mutex provider_mutex;
std::map<cl_device_id, GemmProvider> providers;  // chosen or forced, per device

GemmProvider default_provider() {
  if (const char* env = std::getenv("NOVA_GEMM"); env && *env) return parse_gemm_provider(env, "NOVA_GEMM");
  return GemmProvider::Tuned;
}

bool own_kernels_fit(const GemmArgs& g) { return !(g.trans_a && g.trans_b); }

// Floats of scratch the own kernels need: B^T when B is transposed.
size_t own_temp_floats(const GemmArgs& g) { return g.trans_b ? g.batch * g.k * g.n : 0; }

// T = B^T for op(B) = B^T (B stored [n, k]); returns T's leading dimension and stride.
void transpose_b(Runtime& rt, const GemmArgs& g, cl_mem t) {
  using detail::u32;
  rt.launch("gemm", "gemm_transpose")
      .arg(g.b).arg(t).arg(u32(g.n, "gemm n")).arg(u32(g.k, "gemm k"))
      .arg(u32(g.ldb, "gemm ldb")).arg(u32(g.stride_b, "gemm stride_b"))
      .arg(u32(g.batch, "gemm batch"))
      .run2(g.n, g.k * g.batch);
}

// Build options and arguments of the epilogue (GEMM_BIAS_ACT in kernels/gemm.cl). Without
// one the kernels never read the bias argument; C stands in for it.
std::string epilogue_options(const GemmEpilogue& e) {
  if (!e.bias) return "";
  return ActivationParams{static_cast<int>(e.act)}.gemm_epilogue_defines();
}
Launch& epilogue_args(Launch& l, const GemmArgs& g, const GemmEpilogue& e) {
  return l.arg(e.bias ? e.bias : g.c).arg(detail::u32(e.stride_bias, "gemm bias stride"));
}

// The epilogue as a pass of its own over C (a provider that cannot fuse it): bias_act.cl's
// bias_act_forward in place, which needs C dense.
void epilogue_pass(Runtime& rt, const GemmArgs& g, const GemmEpilogue& e) {
  using detail::u32;
  if (g.ldc != g.n || (g.batch > 1 && (g.stride_c != g.m * g.n || e.stride_bias != g.n)))
    throw Error("GEMM epilogue: a separate pass needs C dense and one bias row per batch",
                kExitInternal);
  detail::bias_act_forward(rt, {g.batch, g.m, g.n}, e.act, g.c, e.bias, g.c);
}

void own_gemm(Runtime& rt, const GemmArgs& g, cl_mem temp, const GemmEpilogue& epi) {
  using detail::u32;
  cl_mem b = g.b;
  size_t ldb = g.ldb, stride_b = g.stride_b;
  Buffer scratch;
  if (g.trans_b) {  // op(B) = B^T, B stored [n, k]: write its transpose [k, n]
    if (!temp) {
      scratch = rt.alloc(own_temp_floats(g) * sizeof(float));
      temp = scratch.get();
    }
    transpose_b(rt, g, temp);
    b = temp;
    ldb = g.n;
    stride_b = g.k * g.n;
  }
  // gemm_nn: work-items over rows x blocks of 16 columns; gemm_tn: over columns x blocks of
  // 8 rows (GEMM_NB and GEMM_MB of kernels/gemm.cl).
  const size_t items0 = g.trans_a ? g.n : g.m;
  const size_t blocks = g.trans_a ? (g.m + 7) / 8 : (g.n + 15) / 16;
  Launch l = rt.launch("gemm", g.trans_a ? "gemm_tn" : "gemm_nn", epilogue_options(epi));
  l.arg(g.a).arg(b).arg(g.c).arg(u32(g.m, "gemm m")).arg(u32(g.n, "gemm n"))
      .arg(u32(g.k, "gemm k")).arg(u32(g.lda, "gemm lda")).arg(u32(ldb, "gemm ldb"))
      .arg(u32(g.ldc, "gemm ldc")).arg(u32(g.stride_a, "gemm stride_a"))
      .arg(u32(stride_b, "gemm stride_b")).arg(u32(g.stride_c, "gemm stride_c"))
      .arg(u32(g.batch, "gemm batch")).arg(g.alpha).arg(g.beta);
  if (!g.trans_a) epilogue_args(l, g, epi);
  l.run2(items0, blocks * g.batch);
}

// ---- the register-blocked kernel (gemm_blk) ------------------------------------------------
size_t blocked_splits(const GemmArgs& g, const BlockedGemmParams& p) {
  return p.kc == 0 || g.k <= p.kc ? 1 : (g.k + p.kc - 1) / p.kc;
}

// Floats of A^T in the scratch (TA=1 with op(A) = A^T).
size_t blocked_at_floats(const GemmArgs& g, const BlockedGemmParams& p) {
  return p.ta && g.trans_a ? g.batch * g.m * g.k : 0;
}

// B^T first (when op(B) = B^T), then A^T (TA=1), then the partial sums of a split reduction.
size_t blocked_temp_floats(const GemmArgs& g, const BlockedGemmParams& p) {
  const size_t splits = blocked_splits(g, p);
  return own_temp_floats(g) + blocked_at_floats(g, p) +
         (splits > 1 ? splits * g.batch * g.m * g.n : 0);
}

void blocked_gemm(Runtime& rt, const GemmConfig& cfg, const GemmArgs& g, cl_mem temp,
                  const GemmEpilogue& epi) {
  using detail::u32;
  const BlockedGemmParams p = blocked_gemm_params(cfg);
  if (g.trans_a && g.trans_b) throw Error("blocked GEMM: A^T B^T is not supported");
  const size_t splits = blocked_splits(g, p);
  Buffer scratch;
  if (const size_t floats = blocked_temp_floats(g, p); floats && !temp) {
    scratch = rt.alloc(floats * sizeof(float));
    temp = scratch.get();
  }
  cl_mem b = g.b;
  size_t ldb = g.ldb, stride_b = g.stride_b;
  if (g.trans_b) {
    transpose_b(rt, g, temp);
    b = temp;
    ldb = g.n;
    stride_b = g.k * g.n;
  }
  const std::string options = p.to_defines() + epilogue_options(epi);
  cl_mem a = g.a;
  size_t a_rs = g.trans_a ? 1 : g.lda, a_cs = g.trans_a ? g.lda : 1, stride_a = g.stride_a;
  size_t poff = own_temp_floats(g);
  if (const size_t at = blocked_at_floats(g, p)) {
    // A stored [k, m] (leading dimension lda): its transpose [m, k] at the start of the
    // scratch (no B^T region: A^T B^T is refused above).
    rt.launch("gemm", "gemm_transpose")
        .arg(g.a).arg(temp).arg(u32(g.k, "gemm k")).arg(u32(g.m, "gemm m"))
        .arg(u32(g.lda, "gemm lda")).arg(u32(g.stride_a, "gemm stride_a"))
        .arg(u32(g.batch, "gemm batch"))
        .run2(g.k, g.m * g.batch);
    a = temp;
    a_rs = g.k;
    a_cs = 1;
    stride_a = g.m * g.k;
    poff += at;
  }
  const size_t kc = splits > 1 ? p.kc : std::max<size_t>(g.k, 1);
  Launch blk = rt.launch("gemm", "gemm_blk", options);
  blk.arg(a).arg(b).arg(g.c).arg(splits > 1 ? temp : g.c).arg(u32(poff, "gemm partials"))
      .arg(u32(g.m, "gemm m")).arg(u32(g.n, "gemm n")).arg(u32(g.k, "gemm k"))
      .arg(u32(a_rs, "gemm lda")).arg(u32(a_cs, "gemm lda"))
      .arg(u32(ldb, "gemm ldb")).arg(u32(g.ldc, "gemm ldc"))
      .arg(u32(stride_a, "gemm stride_a")).arg(u32(stride_b, "gemm stride_b"))
      .arg(u32(g.stride_c, "gemm stride_c")).arg(u32(g.batch, "gemm batch"))
      .arg(u32(kc, "gemm kc")).arg(u32(splits, "gemm splits")).arg(g.alpha).arg(g.beta);
  epilogue_args(blk, g, epi);
  const size_t bn = 8 * p.vn;
  const WorkGroupCap group = device_tuning(rt.info()).blocked_gemm_group;
  blk.run2((g.n + bn - 1) / bn, (g.m + p.rm - 1) / p.rm * g.batch * splits, group.items,
           group.items0);
  if (splits > 1) {
    Launch reduce = rt.launch("gemm", "gemm_reduce", options);
    reduce.arg(temp).arg(u32(poff, "gemm partials")).arg(g.c).arg(u32(g.m, "gemm m"))
        .arg(u32(g.n, "gemm n")).arg(u32(g.ldc, "gemm ldc"))
        .arg(u32(g.stride_c, "gemm stride_c")).arg(u32(g.batch, "gemm batch"))
        .arg(u32(splits, "gemm splits")).arg(g.alpha).arg(g.beta);
    epilogue_args(reduce, g, epi).run2(g.n, g.m * g.batch);
  }
}

const GemmConfig& table_config() {
  static const GemmConfig c;  // "clblast" without parameters: the device's table entry
  return c;
}

// The table's CLBlast for a product without a tuned winner (and, on a CPU, without a host
// BLAS). The weight gradient (A^T B with a long k and a small output: 256 x 256 summed over
// 65536 samples) is split into chunks of k, at most 32 of at least 2048 values: unsplit,
// CLBlast's few work-groups leave most of the device idle. Split, the product ran 5.4x
// faster on an H200 (14.8 against 2.7 TFLOP/s, docs/gpu.md) and 1.27x on 2 PoCL cores (72.6
// against 57.0 GFLOP/s; 64 x 64 over 16384: 75.8 against 44.2).
GemmConfig untuned_config(const GemmArgs& g) {
  if (!g.trans_a || g.trans_b || g.k < 8192 || g.k < 16 * std::max(g.m, g.n))
    return table_config();
  size_t kc = 2048;
  while (g.k > 32 * kc) kc *= 2;
  return GemmConfig{"clblast", {{"KC", kc}}};
}

// The configuration a call runs with under the runtime's provider.
GemmConfig choose(Runtime& rt, const GemmArgs& g) {
  switch (gemm_provider(rt)) {
    case GemmProvider::Kernels:
      if (own_kernels_fit(g)) return GemmConfig{"kernels", {}};
      return table_config();
    case GemmProvider::Host:
      return GemmConfig{"host", {}};
    case GemmProvider::Tuned:
      if (auto c = tuned_gemm_config(rt, g)) return *c;
      // Without a measured winner a CPU device takes its host BLAS: on a 2-core AVX-512
      // Xeon it ran the MLP layers' products 2-4x faster than the untuned device kernels
      // (docs/performance.md); a GPU (or a CPU without one) keeps the table's CLBlast, with
      // the weight gradient split along k (untuned_config).
      if (host_gemm_available(rt)) return GemmConfig{"host", {}};
      return untuned_config(g);
    case GemmProvider::CLBlast:  // CLBlast as it comes: no split
      break;
  }
  return table_config();
}

}  // namespace

const char* gemm_provider_name(GemmProvider p) {
  switch (p) {
    case GemmProvider::Kernels: return "kernels";
    case GemmProvider::CLBlast: return "clblast";
    case GemmProvider::Host: return "host";
    case GemmProvider::Tuned: break;
  }
  return "tuned";
}

GemmProvider parse_gemm_provider(const std::string& name, const std::string& what) {
  for (GemmProvider p : {GemmProvider::Tuned, GemmProvider::CLBlast, GemmProvider::Kernels, GemmProvider::Host})
    if (name == gemm_provider_name(p)) return p;
  throw Error(what + "='" + name + "' is not one of tuned, clblast, kernels, host");
}

GemmProvider gemm_provider(Runtime& rt) {
  std::lock_guard<std::mutex> lock(provider_mutex);
  auto it = providers.find(rt.device());
  if (it == providers.end()) it = providers.emplace(rt.device(), default_provider()).first;
  return it->second;
}

void set_gemm_provider(Runtime& rt, GemmProvider p) {
  std::lock_guard<std::mutex> lock(provider_mutex);
  providers[rt.device()] = p;
}

bool gemm_fuses_epilogue(const GemmConfig& cfg, const GemmArgs& g, Activation act) {
  if (cfg.provider == "host") return host_gemm_fuses(g, act);
  return cfg.provider == "blocked" || (cfg.provider == "kernels" && !g.trans_a);
}

GemmConfig gemm_choice(Runtime& rt, const GemmArgs& g) {
  configure_gemm(rt);
  return choose(rt, g);
}

void gemm_with(Runtime& rt, const GemmConfig& cfg, const GemmArgs& g, cl_mem temp,
               const GemmEpilogue& epi) {
  if (g.m == 0 || g.n == 0 || g.batch == 0) return;
  configure_gemm(rt);
  if (epi.bias && !gemm_fuses_epilogue(cfg, g, epi.act))
    throw Error("GEMM configuration '" + cfg.str() + "' cannot fuse a bias + activation");
  if (cfg.provider == "kernels") {
    if (!own_kernels_fit(g)) throw Error("own GEMM kernels: A^T B^T is not supported");
    return own_gemm(rt, g, temp, epi);
  }
  if (cfg.provider == "blocked") return blocked_gemm(rt, cfg, g, temp, epi);
  if (cfg.provider == "host") return host_gemm(rt, g, epi);
  if (cfg.provider == "clblast") return clblast_gemm(rt, cfg, g, temp);
  throw Error("unknown GEMM provider '" + cfg.provider + "'");
}

size_t gemm_temp_bytes_with(Runtime& rt, const GemmConfig& cfg, const GemmArgs& g) {
  configure_gemm(rt);
  if (cfg.provider == "kernels") return own_temp_floats(g) * sizeof(float);
  if (cfg.provider == "blocked") return blocked_temp_floats(g, blocked_gemm_params(cfg)) * sizeof(float);
  if (cfg.provider == "host") return 0;
  return clblast_temp_bytes(rt, cfg, g);
}

void gemm(Runtime& rt, const GemmArgs& g, cl_mem temp, const GemmEpilogue& epi) {
  if (g.m == 0 || g.n == 0 || g.batch == 0) return;
  configure_gemm(rt);
  const GemmConfig cfg = choose(rt, g);
  // The workspace was sized for the shape a graph was planned with; a call with fewer rows
  // may fall into another shape class with another configuration. A workspace too small for
  // it is not used: the provider allocates its own scratch (CLBlast does the same).
  if (temp) {
    size_t have = 0;
    cl_check(clGetMemObjectInfo(temp, CL_MEM_SIZE, sizeof(have), &have, nullptr),
             "clGetMemObjectInfo(gemm temp)");
    if (have < gemm_temp_bytes_with(rt, cfg, g)) temp = nullptr;
  }
  if (!epi.bias || gemm_fuses_epilogue(cfg, g, epi.act)) return gemm_with(rt, cfg, g, temp, epi);
  gemm_with(rt, cfg, g, temp);
  epilogue_pass(rt, g, epi);
}

size_t gemm_temp_bytes(Runtime& rt, const GemmArgs& g) {
  configure_gemm(rt);
  return gemm_temp_bytes_with(rt, choose(rt, g), g);
}

GemmRunner gemm_runner() {
  return {[](Runtime& rt, const GemmConfig& cfg, const GemmArgs& g, cl_mem temp) {
            gemm_with(rt, cfg, g, temp);
          },
          gemm_temp_bytes_with};
}

GemmSearchResult search_gemm(Runtime& rt, const GemmShapeClass& shape,
                             const std::vector<GemmCandidate>& candidates,
                             const GemmSearchOptions& options) {
  return search_gemm(rt, shape, candidates, gemm_runner(), options);
}

std::vector<GemmCandidate> gemm_candidates(Runtime& rt, const GemmShapeClass& shape, bool quick) {
  return gemm_candidates(rt, shape, quick, host_gemm_available(rt));
}

}  // namespace nova

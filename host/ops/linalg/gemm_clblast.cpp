// The "clblast" GEMM provider: CLBlast with the Xgemm parameters of the device's entry in the
// tuning database (applied once per device) or of an explicit configuration (applied before
// the call that asks for it, and the table's set restored by the next call without one).
// KC=n splits the reduction over k into chunks of n (see clblast_split_gemm).
#include "ops/linalg/gemm_clblast.hpp"

#include <clblast.h>

#include <map>
#include <mutex>
#include <string>
#include <unordered_map>

#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

using Params = std::unordered_map<std::string, size_t>;

// What CLBlast holds per device: its own Xgemm parameters (read before the table is applied)
// and the Xgemm set applied now.
struct DeviceState {
  Params library_xgemm;
  std::string applied;  // GemmConfig::str() of the Xgemm set CLBlast holds now
};

// CLBlast's parameter database is global: every override and every call under this mutex.
std::mutex clblast_mutex;
std::map<cl_device_id, DeviceState> states;

// The Xgemm parameters of cfg: every parameter but KC, which is nova's, not CLBlast's.
GemmConfig xgemm_part(const GemmConfig& cfg) {
  GemmConfig x = cfg;
  x.params.erase("KC");
  return x;
}

// Called with clblast_mutex held.
void apply_clblast_config(Runtime& rt, const GemmConfig& cfg_in) {
  const GemmConfig cfg = xgemm_part(cfg_in);
  DeviceState& st = states[rt.device()];
  const std::string sig = cfg.str();
  if (st.applied == sig) return;
  const DeviceTuning& table = device_tuning(rt.info());
  Params params = st.library_xgemm;
  if (table.xgemm)
    for (const auto& [k, v] : table.xgemm->params()) params[k] = v;
  for (const auto& [k, v] : cfg.params) {
    if (!cfg.params.empty() && !params.empty() && !params.count(k))
      throw Error("GEMM configuration '" + sig + "': CLBlast's Xgemm has no parameter " + k);
    params[k] = v;
  }
  if (params.empty()) {  // nothing known and nothing asked: CLBlast's defaults are in force
    st.applied = sig;
    return;
  }
  st.applied.clear();
  const auto status = clblast::OverrideParameters(rt.device(), "Xgemm",
                                                  clblast::Precision::kSingle, params);
  if (status != clblast::StatusCode::kSuccess)
    throw Error("CLBlast rejected the Xgemm parameters of '" + sig + "' (status " +
                std::to_string(static_cast<int>(status)) + ")");
  st.applied = sig;
}

void override_or_throw(Runtime& rt, const std::string& kernel, const Params& params) {
  const auto status =
      clblast::OverrideParameters(rt.device(), kernel, clblast::Precision::kSingle, params);
  if (status != clblast::StatusCode::kSuccess)
    throw Error("CLBlast rejected the tuning of " + kernel + " (status " +
                    std::to_string(static_cast<int>(status)) + ")",
                kExitInternal);
}

clblast::Transpose tr(bool t) { return t ? clblast::Transpose::kYes : clblast::Transpose::kNo; }

void check(clblast::StatusCode st, const char* what, const GemmArgs& g) {
  if (st == clblast::StatusCode::kSuccess) return;
  throw Error(std::string(what) + " failed with CLBlast status " +
                  std::to_string(static_cast<int>(st)) + " (m=" + std::to_string(g.m) +
                  " n=" + std::to_string(g.n) + " k=" + std::to_string(g.k) +
                  " batch=" + std::to_string(g.batch) + ")",
              kExitInternal);
}

}  // namespace

void configure_gemm(Runtime& rt) {
  {
    std::lock_guard<std::mutex> lock(clblast_mutex);
    if (!states.count(rt.device())) {
      DeviceState& st = states[rt.device()];
      Params lib;
      if (clblast::RetrieveParameters(rt.device(), "Xgemm", clblast::Precision::kSingle, lib) ==
          clblast::StatusCode::kSuccess)
        st.library_xgemm = lib;
      const DeviceTuning& table = device_tuning(rt.info());
      if (table.xgemm) override_or_throw(rt, "Xgemm", table.xgemm->params());
      if (table.xgemm_min_indirect_size)
        override_or_throw(rt, "GemmRoutine",
                          {{"XGEMM_MIN_INDIRECT_SIZE", *table.xgemm_min_indirect_size}});
      st.applied = GemmConfig{}.str();
    }
  }
  load_gemm_cache(rt);
}

size_t clblast_splits(const GemmConfig& cfg, const GemmArgs& g) {
  const auto it = cfg.params.find("KC");
  if (it == cfg.params.end() || it->second == 0 || g.k <= it->second) return 1;
  return (g.k + it->second - 1) / it->second;
}

namespace {

// Split-K: a product whose output is small and whose reduction is long (the weight gradient
// X^T dY, a 256 x 256 output summed over 65536 samples) gives CLBlast a handful of
// work-groups, too few for a GPU. Chunk s of kc values of k goes to its own plane of the
// partial sums P ([splits][batch][m][n] floats at the start of temp), all full chunks of one
// network in one strided-batched call; gemm_reduce then adds the planes in order s = 0, 1, ...
// (no atomics: bit-reproducible) and applies alpha and beta. Called with clblast_mutex held.
void clblast_split_gemm(Runtime& rt, size_t kc, size_t splits, const GemmArgs& g, cl_mem temp) {
  using detail::u32;
  const size_t plane = g.batch * g.m * g.n, full = g.k / kc, rest = g.k - full * kc;
  Buffer scratch;
  if (!temp) {
    scratch = rt.alloc(splits * plane * sizeof(float));
    temp = scratch.get();
  }
  // Zeroed first: with beta = 0 a BLAS may still read C, and 0 * NaN from stale memory is NaN.
  rt.fill_zero(temp, splits * plane * sizeof(float));
  const size_t a_step = g.trans_a ? kc * g.lda : kc, b_step = g.trans_b ? kc : kc * g.ldb;
  for (size_t b = 0; b < g.batch; ++b) {
    const size_t a0 = b * g.stride_a, b0 = b * g.stride_b, c0 = b * g.m * g.n;
    if (full > 0) {
      rt.count_library_call();
      check(clblast::GemmStridedBatched(clblast::Layout::kRowMajor, tr(g.trans_a), tr(g.trans_b),
                                        g.m, g.n, kc, 1.0f, g.a, a0, g.lda, a_step, g.b, b0,
                                        g.ldb, b_step, 0.0f, temp, c0, g.n, plane, full,
                                        rt.queue_ptr(), nullptr),
            "clblast::GemmStridedBatched (split)", g);
    }
    if (rest > 0) {
      rt.count_library_call();
      check(clblast::Gemm(clblast::Layout::kRowMajor, tr(g.trans_a), tr(g.trans_b), g.m, g.n,
                          rest, 1.0f, g.a, a0 + full * a_step, g.lda, g.b, b0 + full * b_step,
                          g.ldb, 0.0f, temp, c0 + full * plane, g.n, rt.queue_ptr(), nullptr),
            "clblast::Gemm (split remainder)", g);
    }
  }
  rt.launch("gemm", "gemm_reduce")
      .arg(temp).arg(0u).arg(g.c).arg(u32(g.m, "gemm m")).arg(u32(g.n, "gemm n"))
      .arg(u32(g.ldc, "gemm ldc")).arg(u32(g.stride_c, "gemm stride_c"))
      .arg(u32(g.batch, "gemm batch")).arg(u32(splits, "gemm splits")).arg(g.alpha).arg(g.beta)
      .arg(g.c).arg(0u)  // no epilogue: the bias argument is never read
      .run2(g.n, g.m * g.batch);
}

}  // namespace

void clblast_gemm(Runtime& rt, const GemmConfig& cfg, const GemmArgs& g, cl_mem temp) {
  std::lock_guard<std::mutex> lock(clblast_mutex);
  apply_clblast_config(rt, cfg);
  if (const size_t splits = clblast_splits(cfg, g); splits > 1)
    return clblast_split_gemm(rt, cfg.params.at("KC"), splits, g, temp);
  rt.count_library_call();
  if (g.batch == 1) {
    check(clblast::Gemm(clblast::Layout::kRowMajor, tr(g.trans_a), tr(g.trans_b), g.m, g.n, g.k,
                        g.alpha, g.a, 0, g.lda, g.b, 0, g.ldb, g.beta, g.c, 0, g.ldc,
                        rt.queue_ptr(), nullptr, temp),
          "clblast::Gemm", g);
  } else {
    check(clblast::GemmStridedBatched(clblast::Layout::kRowMajor, tr(g.trans_a), tr(g.trans_b),
                                      g.m, g.n, g.k, g.alpha, g.a, 0, g.lda, g.stride_a, g.b, 0,
                                      g.ldb, g.stride_b, g.beta, g.c, 0, g.ldc, g.stride_c,
                                      g.batch, rt.queue_ptr(), nullptr),
          "clblast::GemmStridedBatched", g);
  }
}

size_t clblast_temp_bytes(Runtime& rt, const GemmConfig& cfg, const GemmArgs& g) {
  // Split: the partial sums (CLBlast's calls on the chunks allocate their own scratch).
  if (const size_t splits = clblast_splits(cfg, g); splits > 1)
    return splits * g.batch * g.m * g.n * sizeof(float);
  if (g.batch != 1) return 0;  // the batched routine allocates its own scratch
  std::lock_guard<std::mutex> lock(clblast_mutex);
  apply_clblast_config(rt, cfg);
  size_t bytes = 0;
  check(clblast::GemmTempBufferSize<float>(clblast::Layout::kRowMajor, tr(g.trans_a),
                                           tr(g.trans_b), g.m, g.n, g.k, 0, g.lda, 0, g.ldb, 0,
                                           g.ldc, rt.queue_ptr(), bytes),
        "clblast::GemmTempBufferSize", g);
  return bytes;
}

}  // namespace nova

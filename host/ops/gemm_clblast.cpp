// The "clblast" GEMM provider: CLBlast with the Xgemm parameters of the device's entry in the
// tuning database (applied once per device) or of an explicit configuration (applied before
// the call that asks for it, and the table's set restored by the next call without one).
#include "gemm_clblast.hpp"

#include <clblast.h>

#include <map>
#include <mutex>
#include <string>
#include <unordered_map>

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

// Called with clblast_mutex held.
void apply_clblast_config(Runtime& rt, const GemmConfig& cfg) {
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

void clblast_gemm(Runtime& rt, const GemmConfig& cfg, const GemmArgs& g, cl_mem temp) {
  std::lock_guard<std::mutex> lock(clblast_mutex);
  apply_clblast_config(rt, cfg);
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

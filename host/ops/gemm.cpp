// The GEMM providers: CLBlast, and nova's own kernels for CPU devices (kernels/gemm.cl).
#include "nova/gemm.hpp"

#include <clblast.h>

#include <cstdlib>
#include <map>
#include <mutex>

#include "op_util.hpp"

namespace nova {
namespace {

std::mutex provider_mutex;
std::map<cl_device_id, GemmProvider> providers;  // chosen or forced, per device

GemmProvider default_provider() {
  if (const char* env = std::getenv("NOVA_GEMM"); env && *env) {
    const std::string v = env;
    if (v == "clblast") return GemmProvider::CLBlast;
    if (v == "kernels") return GemmProvider::Kernels;
    throw Error("NOVA_GEMM='" + v + "' is not one of clblast, kernels");
  }
  return GemmProvider::CLBlast;  // the own kernels do not beat it yet (gemm.hpp)
}

bool own_kernels_fit(const GemmArgs& g) { return !(g.trans_a && g.trans_b); }

// Floats of scratch the own kernels need: B^T when B is transposed.
size_t own_temp_floats(const GemmArgs& g) { return g.trans_b ? g.batch * g.k * g.n : 0; }

void own_gemm(Runtime& rt, const GemmArgs& g, cl_mem temp) {
  using detail::u32;
  cl_mem b = g.b;
  size_t ldb = g.ldb, stride_b = g.stride_b;
  Buffer scratch;
  if (g.trans_b) {  // op(B) = B^T, B stored [n, k]: write its transpose [k, n]
    if (!temp) {
      scratch = rt.alloc(own_temp_floats(g) * sizeof(float));
      temp = scratch.get();
    }
    rt.launch("gemm", "gemm_transpose")
        .arg(g.b).arg(temp).arg(u32(g.n, "gemm n")).arg(u32(g.k, "gemm k"))
        .arg(u32(g.ldb, "gemm ldb")).arg(u32(g.stride_b, "gemm stride_b"))
        .arg(u32(g.batch, "gemm batch"))
        .run2(g.n, g.k * g.batch);
    b = temp;
    ldb = g.n;
    stride_b = g.k * g.n;
  }
  // gemm_nn: work-items over rows x blocks of 16 columns; gemm_tn: over columns x blocks of
  // 8 rows (GEMM_NB and GEMM_MB of kernels/gemm.cl).
  const size_t items0 = g.trans_a ? g.n : g.m;
  const size_t blocks = g.trans_a ? (g.m + 7) / 8 : (g.n + 15) / 16;
  rt.launch("gemm", g.trans_a ? "gemm_tn" : "gemm_nn")
      .arg(g.a).arg(b).arg(g.c).arg(u32(g.m, "gemm m")).arg(u32(g.n, "gemm n"))
      .arg(u32(g.k, "gemm k")).arg(u32(g.lda, "gemm lda")).arg(u32(ldb, "gemm ldb"))
      .arg(u32(g.ldc, "gemm ldc")).arg(u32(g.stride_a, "gemm stride_a"))
      .arg(u32(stride_b, "gemm stride_b")).arg(u32(g.stride_c, "gemm stride_c"))
      .arg(u32(g.batch, "gemm batch")).arg(g.alpha).arg(g.beta)
      .run2(items0, blocks * g.batch);
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

const char* gemm_provider_name(GemmProvider p) {
  return p == GemmProvider::Kernels ? "kernels" : "clblast";
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

void gemm(Runtime& rt, const GemmArgs& g, cl_mem temp) {
  if (g.m == 0 || g.n == 0 || g.batch == 0) return;
  if (gemm_provider(rt) == GemmProvider::Kernels && own_kernels_fit(g)) return own_gemm(rt, g, temp);
  configure_gemm(rt);
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

size_t gemm_temp_bytes(Runtime& rt, const GemmArgs& g) {
  if (gemm_provider(rt) == GemmProvider::Kernels && own_kernels_fit(g))
    return own_temp_floats(g) * sizeof(float);
  if (g.batch != 1) return 0;  // the batched routine allocates its own scratch
  configure_gemm(rt);
  size_t bytes = 0;
  check(clblast::GemmTempBufferSize<float>(clblast::Layout::kRowMajor, tr(g.trans_a),
                                           tr(g.trans_b), g.m, g.n, g.k, 0, g.lda, 0, g.ldb, 0,
                                           g.ldc, rt.queue_ptr(), bytes),
        "clblast::GemmTempBufferSize", g);
  return bytes;
}

}  // namespace nova

// The CLBlast GEMM provider.
#include "nova/gemm.hpp"

#include <clblast.h>

namespace nova {
namespace {

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

void gemm(Runtime& rt, const GemmArgs& g, cl_mem temp) {
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

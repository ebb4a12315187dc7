#pragma once
// Row-major single-precision GEMM on a Runtime's queue: C = alpha * op(A) * op(B) + beta * C,
// batched over `batch` matrices spaced by the strides. Two providers:
//  - CLBlast, with kernel parameters from a per-device tuning table (gemm_tuning.cpp);
//  - nova's own kernels (kernels/gemm.cl), written for PoCL's vectorisation across work-items.
//    Measured on the 2-core CPU in a quick-preset hash-grid training step, they run the
//    forward GEMMs about as fast as tuned CLBlast and the backward ones 1.4x slower, so they
//    are not the default yet: NOVA_GEMM=kernels selects them.
// NOVA_GEMM=clblast|kernels chooses the provider; CLBlast is the default on every device. A
// transposed-A-and-B product always goes to CLBlast.
#include <cstddef>
#include <string>
#include <unordered_map>
#include <vector>

#include "nova/runtime.hpp"

namespace nova {

struct GemmArgs {
  bool trans_a = false, trans_b = false;
  size_t m = 0, n = 0, k = 0;
  float alpha = 1.0f;
  cl_mem a = nullptr;
  size_t lda = 0, stride_a = 0;
  cl_mem b = nullptr;
  size_t ldb = 0, stride_b = 0;
  float beta = 0.0f;
  cl_mem c = nullptr;
  size_t ldc = 0, stride_c = 0;
  size_t batch = 1;
};

enum class GemmProvider { CLBlast, Kernels };
const char* gemm_provider_name(GemmProvider p);  // "clblast", "kernels"
// The provider this runtime's GEMMs use (NOVA_GEMM, else by device type); Error on a bad
// NOVA_GEMM value.
GemmProvider gemm_provider(Runtime& rt);
// Forces a provider for this runtime (benchmarks and tests compare them in one process).
void set_gemm_provider(Runtime& rt, GemmProvider p);

// Runs the GEMM; `temp` (gemm_temp_bytes large) avoids an allocation per call.
void gemm(Runtime& rt, const GemmArgs& g, cl_mem temp = nullptr);
size_t gemm_temp_bytes(Runtime& rt, const GemmArgs& g);

// One entry of the tuning table: which devices it fits, and the CLBlast kernel parameters.
struct GemmTuning {
  std::string name;    // shown by `nova devices --verbose` and the benchmark
  std::unordered_map<std::string, std::unordered_map<std::string, size_t>> overrides;
};
// The entry for a device (an empty one for CLBlast's own defaults).
const GemmTuning& gemm_tuning_for(const DeviceInfo& device);
// Applies the device's entry to CLBlast; idempotent.
void configure_gemm(Runtime& rt);

}  // namespace nova

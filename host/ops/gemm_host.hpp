#pragma once
// The "host" GEMM provider (gemm_host.cpp): cblas_sgemm of a run-time loaded host BLAS,
// enqueued as a native kernel on a CPU device's queue.
#include <string>

#include "nova/gemm.hpp"

namespace nova {

// host_gemm_available and host_blas_library are declared in nova/gemm.hpp.
// Enqueues C = alpha op(A) op(B) + beta C, batched; Error when !host_gemm_available(rt).
void host_gemm(Runtime& rt, const GemmArgs& g);

}  // namespace nova

#pragma once
// The "host" GEMM provider (gemm_host.cpp): cblas_sgemm of a run-time loaded host BLAS,
// enqueued as a native kernel on a CPU device's queue.
#include <string>

#include "nova/ops/linalg/gemm.hpp"

namespace nova {

// host_gemm_available and host_blas_library are declared in nova/ops/linalg/gemm.hpp.
// Enqueues C = alpha op(A) op(B) + beta C, batched, then the epilogue if it has a bias (only
// where host_gemm_fuses: gemm_with, its one caller, refuses the rest); Error when
// !host_gemm_available(rt).
void host_gemm(Runtime& rt, const GemmArgs& g, const GemmEpilogue& epi = {});

// Whether host_gemm applies an epilogue of activation `act` to `g` itself: row blocks of C
// (8 MiB), each product followed at once by its bias and activation while the block is in cache
// (a separate pass would read and write all of C from memory again). Only where op(A) keeps
// A's rows (no trans_a) and only the identity and ReLU, whose float results the host computes
// exactly as kernels/bias_act.cl does; the sigmoid and softplus keep the device's pass.
bool host_gemm_fuses(const GemmArgs& g, Activation act);

}  // namespace nova

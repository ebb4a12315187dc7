#pragma once
// The "clblast" GEMM provider (gemm_clblast.cpp): CLBlast's Gemm / GemmStridedBatched with
// the Xgemm parameters of the device's table entry, or of an explicit configuration; with
// KC=n the reduction over k runs in chunks of n added by gemm_reduce (split-K).
#include <cstddef>

#include "nova/ops/linalg/gemm.hpp"

namespace nova {

// configure_gemm is declared in nova/ops/linalg/gemm.hpp.
// Runs `g` through CLBlast with cfg's Xgemm parameters (the table's when cfg.params is empty).
void clblast_gemm(Runtime& rt, const GemmConfig& cfg, const GemmArgs& g, cl_mem temp);
size_t clblast_temp_bytes(Runtime& rt, const GemmConfig& cfg, const GemmArgs& g);
// Chunks of k under cfg's KC (1: no split).
size_t clblast_splits(const GemmConfig& cfg, const GemmArgs& g);

}  // namespace nova

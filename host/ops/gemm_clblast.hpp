#pragma once
// The "clblast" GEMM provider (gemm_clblast.cpp): CLBlast's Gemm / GemmStridedBatched with
// the Xgemm parameters of the device's table entry, or of an explicit configuration.
#include <cstddef>

#include "nova/gemm.hpp"

namespace nova {

// configure_gemm is declared in nova/gemm.hpp.
// Runs `g` through CLBlast with cfg's Xgemm parameters (the table's when cfg.params is empty).
void clblast_gemm(Runtime& rt, const GemmConfig& cfg, const GemmArgs& g, cl_mem temp);
size_t clblast_temp_bytes(Runtime& rt, const GemmConfig& cfg, const GemmArgs& g);

}  // namespace nova

#pragma once
// Row-major single-precision GEMM on a Runtime's queue: C = alpha * op(A) * op(B) + beta * C,
// batched over `batch` matrices spaced by the strides. Providers:
//  - "clblast": CLBlast, with kernel parameters from the per-device table (tuning.hpp)
//    or, for one shape, from an explicit set of Xgemm parameters (clblast::OverrideParameters);
//  - "kernels": nova's first own kernels (gemm_nn / gemm_tn of kernels/gemm.cl);
//  - "blocked": nova's register-blocked kernel (gemm_blk: float8 vectors, RM x 8VN blocks of
//    C per work-item, the reduction split in KC chunks for the weight gradient);
//  - "host": on a CPU device with native kernels, the host BLAS's cblas_sgemm (OpenBLAS, BLIS
//    or MKL, loaded at run time; NOVA_HOST_BLAS=PATH|off) run in queue order on the buffers'
//    shared memory (gemm_host.cpp).
// Which one runs is chosen per device and shape by measurement: `nova tune` searches
// candidates of each provider, checks each against a float64 host reference, and writes the
// winners to the tuning cache (gemm_tuning.hpp), read at start-up by configure_gemm.
// NOVA_GEMM=tuned|clblast|kernels|host forces a mode: tuned (the default) takes the cache's
// winner for the shape, else the host BLAS where the device has one, else the table's CLBlast
// (with the weight gradient's long reduction split into chunks: split-K); clblast ignores the
// cache and never splits. A transposed-A-and-B product goes to CLBlast (or the host BLAS).
//
// A forward layer may ask for an epilogue, C = act(alpha op(A) op(B) + beta C + bias): nova's
// own kernels apply it as they store C (after a split reduction's sum, never to a partial), so
// the output is written once; CLBlast and the host BLAS cannot, and get a second pass over C
// (bias_act_forward of kernels/bias_act.cl, in place).
#include <cstddef>
#include <string>
#include <vector>

#include "nova/tuning/gemm_tuning.hpp"
#include "nova/ops/linalg/dense.hpp"
#include "nova/runtime/runtime.hpp"

namespace nova {

// The bias + activation of a dense layer: C = act(C + bias[b * stride_bias + j]) for column j
// of batch matrix b, applied after the product. No bias: no epilogue. Where CLBlast runs the
// product, C must be dense (ldc = n, stride_c = m n) and stride_bias = n.
struct GemmEpilogue {
  cl_mem bias = nullptr;
  size_t stride_bias = 0;
  Activation act = Activation::Identity;
};

enum class GemmProvider { Tuned, CLBlast, Kernels, Host };
const char* gemm_provider_name(GemmProvider p);  // "tuned", "clblast", "kernels", "host"
// The provider named `name` (gemm_provider_name's forms); Error listing them otherwise, with
// `what` (e.g. "NOVA_GEMM") naming where the name came from.
GemmProvider parse_gemm_provider(const std::string& name, const std::string& what);
// The provider this runtime's GEMMs use (NOVA_GEMM, else tuned); Error on a bad NOVA_GEMM.
GemmProvider gemm_provider(Runtime& rt);
// Forces a provider for this runtime (benchmarks and tests compare them in one process).
void set_gemm_provider(Runtime& rt, GemmProvider p);

// The "host" provider: whether the device is a CPU that runs native kernels and an optimised
// BLAS was found (NOVA_HOST_BLAS: a library to load instead of the search, or "off"), and the
// library that was loaded ("" when none). Error when NOVA_HOST_BLAS names no loadable BLAS.
bool host_gemm_available(const DeviceInfo& device);
inline bool host_gemm_available(Runtime& rt) { return host_gemm_available(rt.info()); }
std::string host_blas_library();

// Runs the GEMM and the epilogue, if any; `temp` (gemm_temp_bytes large) avoids an
// allocation per call.
void gemm(Runtime& rt, const GemmArgs& g, cl_mem temp = nullptr, const GemmEpilogue& epi = {});
size_t gemm_temp_bytes(Runtime& rt, const GemmArgs& g);

// ---- one concrete way to run a GEMM (GemmConfig: gemm_tuning.hpp) -----------------------
// Runs `g` exactly as `cfg` says (no cache, no fallback): the search and tests use it. Throws
// Error when the configuration cannot run this shape (CLBlast refusing parameters included)
// or cannot fuse g's epilogue (gemm_fuses_epilogue).
void gemm_with(Runtime& rt, const GemmConfig& cfg, const GemmArgs& g, cl_mem temp = nullptr,
               const GemmEpilogue& epi = {});
size_t gemm_temp_bytes_with(Runtime& rt, const GemmConfig& cfg, const GemmArgs& g);
// Whether `cfg` applies an epilogue with activation `act` itself: nova's own kernels in their
// store (except gemm_tn), the host BLAS block by block for the identity and ReLU (gemm_host.hpp).
bool gemm_fuses_epilogue(const GemmConfig& cfg, const GemmArgs& g, Activation act);
// The configuration gemm() runs `g` with under the runtime's provider.
GemmConfig gemm_choice(Runtime& rt, const GemmArgs& g);

// ---- the CLBlast table and the search ------------------------------------------------------
// Applies the device's table entry (tuning.hpp's device_tuning) to CLBlast and loads the
// cache's winners for it (load_gemm_cache); idempotent.
void configure_gemm(Runtime& rt);

// The search of gemm_tuning.hpp with candidates run by gemm_with (and sized by
// gemm_temp_bytes_with), and the candidates for this device (the host BLAS among them where
// host_gemm_available).
GemmRunner gemm_runner();
GemmSearchResult search_gemm(Runtime& rt, const GemmShapeClass& shape,
                             const std::vector<GemmCandidate>& candidates,
                             const GemmSearchOptions& options = {});
std::vector<GemmCandidate> gemm_candidates(Runtime& rt, const GemmShapeClass& shape, bool quick);

}  // namespace nova

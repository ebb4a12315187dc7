#pragma once
// Row-major single-precision GEMM on a Runtime's queue: C = alpha * op(A) * op(B) + beta * C,
// batched over `batch` matrices spaced by the strides. Providers:
//  - "clblast": CLBlast, with kernel parameters from the per-device table (gemm_tuning.cpp)
//    or, for one shape, from an explicit set of Xgemm parameters (clblast::OverrideParameters);
//  - "kernels": nova's first own kernels (gemm_nn / gemm_tn of kernels/gemm.cl);
//  - "blocked": nova's register-blocked kernel (gemm_blk: float8 vectors, RM x 8VN blocks of
//    C per work-item, the reduction split in KC chunks for the weight gradient);
//  - "host": on a CPU device with native kernels, the host BLAS's cblas_sgemm (OpenBLAS, BLIS
//    or MKL, loaded at run time; NOVA_HOST_BLAS=PATH|off) run in queue order on the buffers'
//    shared memory (gemm_host.cpp).
// Which one runs is chosen per device and shape by measurement: `nova tune` searches
// candidates of each provider, checks each against a float64 host reference, and writes the
// winners to the tuning cache (gemm_tuning_cache_path), read at start-up by configure_gemm.
// NOVA_GEMM=tuned|clblast|kernels|host forces a mode: tuned (the default) takes the cache's
// winner for the shape, else the host BLAS where the device has one, else the table's CLBlast;
// clblast ignores the cache. A transposed-A-and-B product goes to CLBlast (or the host BLAS).
//
// A forward layer may ask for an epilogue, C = act(alpha op(A) op(B) + beta C + bias): nova's
// own kernels apply it as they store C (after a split reduction's sum, never to a partial), so
// the output is written once; CLBlast and the host BLAS cannot, and get a second pass over C
// (bias_act_forward of kernels/activation.cl, in place).
#include <cstddef>
#include <functional>
#include <iosfwd>
#include <map>
#include <optional>
#include <string>
#include <tuple>
#include <unordered_map>
#include <vector>

#include "nova/ops.hpp"
#include "nova/runtime.hpp"

namespace nova {

// The bias + activation of a dense layer: C = act(C + bias[b * stride_bias + j]) for column j
// of batch matrix b, applied after the product. No bias: no epilogue. Where CLBlast runs the
// product, C must be dense (ldc = n, stride_c = m n) and stride_bias = n.
struct GemmEpilogue {
  cl_mem bias = nullptr;
  size_t stride_bias = 0;
  Activation act = Activation::Identity;
};

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

// ---- one concrete way to run a GEMM -------------------------------------------------------
struct GemmConfig {
  std::string provider = "clblast";  // "clblast", "kernels", "blocked"
  // clblast: Xgemm parameters (MWG, NWG, ...; empty = the device's table entry);
  // blocked: RM, VN, KC (KC = 0: no split).
  std::map<std::string, size_t> params;
  std::string str() const;  // "blocked RM=6 VN=2 KC=1024", "clblast" (the table)
  // Parses str()'s form; Error naming `text` when it is not one.
  static GemmConfig parse(const std::string& text);
  bool operator==(const GemmConfig& o) const { return provider == o.provider && params == o.params; }
};
// Runs `g` exactly as `cfg` says (no cache, no fallback): the search and tests use it. Throws
// Error when the configuration cannot run this shape (CLBlast refusing parameters included)
// or cannot fuse g's epilogue (gemm_fuses_epilogue).
void gemm_with(Runtime& rt, const GemmConfig& cfg, const GemmArgs& g, cl_mem temp = nullptr,
               const GemmEpilogue& epi = {});
size_t gemm_temp_bytes_with(Runtime& rt, const GemmConfig& cfg, const GemmArgs& g);
// Whether `cfg` applies an epilogue in its own store (nova's own kernels, except gemm_tn).
bool gemm_fuses_epilogue(const GemmConfig& cfg, const GemmArgs& g);
// The configuration gemm() runs `g` with under the runtime's provider.
GemmConfig gemm_choice(Runtime& rt, const GemmArgs& g);

// ---- shape classes: what the cache is keyed on --------------------------------------------
// "nn" (X W), "nt" (dY W^T), "tn" (X^T dY), with the two layer widths exact and the long
// dimension (the batch of samples: m for nn/nt, k for tn) as a power of two rounded down.
struct GemmShapeClass {
  std::string kind;  // nn, nt, tn
  size_t m = 0, n = 0, k = 0;
  std::string str() const;  // "nn 16384x256x256" (m x n x k)
  auto key() const { return std::tie(kind, m, n, k); }
  bool operator<(const GemmShapeClass& o) const { return key() < o.key(); }
  bool operator==(const GemmShapeClass& o) const { return key() == o.key(); }
};
// Shorter long dimensions are not tuned (the table's CLBlast runs them).
constexpr size_t kGemmTunedMinRows = 2048;
// The class of a GEMM, or none for a shape that is never tuned (tt, short).
std::optional<GemmShapeClass> gemm_shape_class(const GemmArgs& g);

// ---- the tuning table and the per-device cache ---------------------------------------------
// One entry of the static tuning table: which devices it fits, and the CLBlast parameters.
struct GemmTuning {
  std::string name;    // shown by `nova devices --verbose` and the benchmark
  std::unordered_map<std::string, std::unordered_map<std::string, size_t>> overrides;
};
// The table entry for a device (an empty one for CLBlast's own defaults).
const GemmTuning& gemm_tuning_for(const DeviceInfo& device);

// One winner of the cache: device identity, CLBlast version, shape class, configuration,
// and what the search measured (GFLOP/s; the default = the table's CLBlast).
struct GemmCacheEntry {
  std::string device, vendor, driver, clblast;
  GemmShapeClass shape;
  GemmConfig config;
  double default_gflops = 0, tuned_gflops = 0;
};
// The cache file: $NOVA_TUNING_CACHE, else $XDG_CACHE_HOME/nova/gemm-tuning.tsv, else
// ~/.cache/nova/gemm-tuning.tsv (empty when none of those can be formed).
std::string gemm_tuning_cache_path();
// Reads a cache file: an empty list when it does not exist; Error naming the file and line
// when it is not a cache file.
std::vector<GemmCacheEntry> read_gemm_cache(const std::string& path);
// read_gemm_cache for start-up: a corrupt cache is one warning on `warn` naming the file and
// the line, and an empty list (GEMMs then use the table), never an exception.
std::vector<GemmCacheEntry> read_gemm_cache_or_warn(const std::string& path, std::ostream& warn);
// Writes atomically (a temporary file in the same folder, then rename), creating the folder.
void write_gemm_cache(const std::string& path, const std::vector<GemmCacheEntry>& entries);
// Replaces the entries of `entries`' devices and shapes in the file and keeps the rest.
void merge_gemm_cache(const std::string& path, const std::vector<GemmCacheEntry>& entries);
// A cache entry's identity fields for this device.
GemmCacheEntry gemm_cache_key(const DeviceInfo& device);
std::string clblast_version();

// Applies the device's table entry to CLBlast and loads the cache's winners for it (a
// corrupt cache: one warning on stderr naming the file, then the table alone); idempotent.
void configure_gemm(Runtime& rt);
// Re-reads the cache for this runtime's device (after `nova tune` wrote it); returns how many
// winners it holds for the device. Error naming the file when it is corrupt (the winners are
// then left as they were).
size_t reload_gemm_cache(Runtime& rt, const std::string& path = gemm_tuning_cache_path());
// The winner the tuned mode uses for `g` on this runtime, if any.
std::optional<GemmConfig> tuned_gemm_config(Runtime& rt, const GemmArgs& g);

// ---- the parameter search ------------------------------------------------------------------
struct GemmCandidate {
  GemmConfig config;
  // Tests only: runs instead of gemm_with (e.g. a deliberately wrong product).
  std::function<void(Runtime&, const GemmArgs&, cl_mem temp)> custom;
  std::string label() const { return custom ? "custom " + config.str() : config.str(); }
};
// The candidates for a shape class on this device: the table's CLBlast first, then CLBlast
// Xgemm parameter sets (valid combinations only), the first own kernels, and blocked kernels.
std::vector<GemmCandidate> gemm_candidates(Runtime& rt, const GemmShapeClass& shape, bool quick);

struct GemmTrial {
  std::string label;
  double gflops = 0;       // median of the timed runs; 0 when it failed or was rejected
  double error_ratio = 0;  // worst |error| / bound against the float64 reference
  bool ok = false;
  std::string note;  // why it failed or was rejected
};
struct GemmSearchResult {
  GemmShapeClass shape;
  std::vector<GemmTrial> trials;  // in candidate order; trials[0] is the default
  int winner = -1;                // index into trials / candidates; -1: nothing passed
  GemmConfig config;              // the winner's configuration
  double default_gflops = 0, tuned_gflops = 0;
};
struct GemmSearchOptions {
  int repeats = 3;
  size_t check_rows = 1031;   // the long dimension of the full float64 check
  double max_seconds = 60;    // per shape: later candidates are skipped once it is spent
  std::function<void(const std::string&)> progress;  // one line per candidate
};
// Times every candidate on `shape` (its long dimension as given) and checks each against a
// float64 host reference before it may win: the full product at a short long dimension, and
// sampled rows of the timed product. Bound per element: 2 k u sum |a b| + 2 u |c|, u = 2^-24.
GemmSearchResult search_gemm(Runtime& rt, const GemmShapeClass& shape,
                             const std::vector<GemmCandidate>& candidates,
                             const GemmSearchOptions& options = {});
// Worst |got - ref| / bound of C = alpha op(A) op(B) + beta C0 over the rows `rows` of C
// (all rows when empty), against a float64 product; inputs as the host copies.
double gemm_error_ratio(const GemmArgs& g, const std::vector<float>& a,
                        const std::vector<float>& b, const std::vector<float>& c0,
                        const std::vector<float>& got, const std::vector<size_t>& rows = {});

}  // namespace nova

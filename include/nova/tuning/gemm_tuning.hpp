#pragma once
// GEMM tuning: the configurations a GEMM can run with, the shape classes the per-device cache
// of measured winners is keyed on, the cache file, and the search behind `nova tune`, which
// times candidates and checks each against a float64 host reference before it may win. The
// GEMM op (gemm.hpp) asks this module which configuration to run; the search runs candidates
// through the op's functions, handed in as a GemmRunner (gemm.hpp's search_gemm does that).
#include <cstddef>
#include <functional>
#include <iosfwd>
#include <map>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "nova/runtime/runtime.hpp"
#include "nova/tuning/tuning.hpp"

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

// ---- one concrete way to run a GEMM -------------------------------------------------------
struct GemmConfig {
  std::string provider = "clblast";  // "clblast", "kernels", "blocked", "host"
  // clblast: Xgemm parameters (MWG, NWG, ...; empty = the device's table entry) and nova's
  // KC (split the reduction over k in chunks of KC; absent or 0: no split);
  // blocked: RM, VN, KC (KC = 0: no split), TA.
  std::map<std::string, size_t> params;
  std::string str() const;  // "blocked RM=6 VN=2 KC=1024", "clblast" (the table)
  // Parses str()'s form; Error naming `text` when it is not one.
  static GemmConfig parse(const std::string& text);
  bool operator==(const GemmConfig& o) const { return provider == o.provider && params == o.params; }
};
// A blocked configuration's parameters (unnamed ones at BlockedGemmParams' defaults); Error
// naming the configuration for an unknown parameter or one out of range.
BlockedGemmParams blocked_gemm_params(const GemmConfig& config);

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

// ---- the per-device cache ------------------------------------------------------------------
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

// Loads the cache's winners for this runtime's device once (a corrupt cache: one warning on
// stderr naming the file, then the table alone); later calls keep what is loaded.
void load_gemm_cache(Runtime& rt);
// Re-reads the cache for this runtime's device (after `nova tune` wrote it); returns how many
// winners it holds for the device. Error naming the file when it is corrupt (the winners are
// then left as they were).
size_t reload_gemm_cache(Runtime& rt, const std::string& path = gemm_tuning_cache_path());
// The winner the tuned mode uses for `g` on this runtime, if any: the cache's entry for the
// shape class, else the nearest tuned long dimension within a factor of 4.
std::optional<GemmConfig> tuned_gemm_config(Runtime& rt, const GemmArgs& g);

// ---- the parameter search ------------------------------------------------------------------
struct GemmCandidate {
  GemmConfig config;
  // Tests only: runs instead of the runner (e.g. a deliberately wrong product).
  std::function<void(Runtime&, const GemmArgs&, cl_mem temp)> custom;
  std::string label() const { return custom ? "custom " + config.str() : config.str(); }
};
// The candidates for a shape class on this device: the table's CLBlast first, then CLBlast
// Xgemm parameter sets (valid combinations only), the first own kernels, the host BLAS (when
// `host_blas`: the device has one), and blocked kernels.
std::vector<GemmCandidate> gemm_candidates(Runtime& rt, const GemmShapeClass& shape, bool quick,
                                           bool host_blas);

// How the search runs a configuration exactly as it says (no cache, no fallback), and the
// scratch it needs: the GEMM op's gemm_with and gemm_temp_bytes_with.
struct GemmRunner {
  std::function<void(Runtime&, const GemmConfig&, const GemmArgs&, cl_mem temp)> run;
  std::function<size_t(Runtime&, const GemmConfig&, const GemmArgs&)> temp_bytes;
};

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
                             const GemmRunner& runner, const GemmSearchOptions& options = {});
// Worst |got - ref| / bound of C = alpha op(A) op(B) + beta C0 over the rows `rows` of C
// (all rows when empty), against a float64 product; inputs as the host copies.
double gemm_error_ratio(const GemmArgs& g, const std::vector<float>& a,
                        const std::vector<float>& b, const std::vector<float>& c0,
                        const std::vector<float>& got, const std::vector<size_t>& rows = {});

}  // namespace nova

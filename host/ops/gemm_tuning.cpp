// GEMM tuning: the static per-device table (CLBlast kernel parameters that beat its defaults),
// the per-device cache of measured winners (`nova tune`), and applying both.
// Table entries are matched on device type and vendor; values come from measurements on the
// device class, not guesses.
#include <clblast.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <sstream>
#include <unistd.h>

#include "nova/gemm.hpp"
#include "runtime/parse_number.hpp"

namespace nova {
namespace {

GemmTuning pocl_cpu() {
  GemmTuning t;
  t.name = "pocl-cpu";
  // Measured on PoCL 3.1 (AVX-512): 12-18 GFLOP/s forward and 17-21 for the weight gradient,
  // against 11.5 / 2.8 with the defaults (a 6x win on dW = X^T dY).
  t.overrides["Xgemm"] = {{"GEMMK", 0}, {"KREG", 1},  {"STRM", 0},  {"STRN", 0},
                          {"SA", 1},    {"SB", 1},    {"MWG", 64},  {"NWG", 64},
                          {"KWG", 16},  {"MDIMC", 8}, {"NDIMC", 8}, {"MDIMA", 8},
                          {"NDIMB", 8}, {"KWI", 2},   {"VWM", 8},   {"VWN", 8}};
  // Always the indirect path: one compiled program instead of two (a cold PoCL compile costs
  // 10-35 s per CLBlast program), and MLP layers are large anyway.
  t.overrides["GemmRoutine"] = {{"XGEMM_MIN_INDIRECT_SIZE", 0}};
  return t;
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

using Params = std::unordered_map<std::string, size_t>;

// What nova knows per device: CLBlast's own Xgemm parameters (read before the table is
// applied), the Xgemm set applied now, and the cache's winners.
struct DeviceState {
  Params library_xgemm;
  std::string applied;  // GemmConfig::str() of the Xgemm set CLBlast holds now
  std::map<GemmShapeClass, GemmConfig> winners;
};

std::recursive_mutex state_mutex;
std::map<cl_device_id, DeviceState> states;

// Tab-separated fields; a field's tab, newline, carriage return and backslash are escaped.
std::string escape(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '\\') o += "\\\\";
    else if (c == '\t') o += "\\t";
    else if (c == '\n') o += "\\n";
    else if (c == '\r') o += "\\r";
    else o += c;
  }
  return o;
}

bool unescape(const std::string& s, std::string& o) {
  o.clear();
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] != '\\') {
      o += s[i];
      continue;
    }
    if (++i == s.size()) return false;
    if (s[i] == '\\') o += '\\';
    else if (s[i] == 't') o += '\t';
    else if (s[i] == 'n') o += '\n';
    else if (s[i] == 'r') o += '\r';
    else return false;
  }
  return true;
}

std::vector<std::string> split_tabs(const std::string& line) {
  std::vector<std::string> f;
  size_t start = 0;
  for (;;) {
    const size_t t = line.find('\t', start);
    f.push_back(line.substr(start, t == std::string::npos ? std::string::npos : t - start));
    if (t == std::string::npos) return f;
    start = t + 1;
  }
}

constexpr const char* kMagic = "nova-gemm-tuning\t1";

GemmShapeClass parse_shape(const std::string& text) {
  GemmShapeClass s;
  std::istringstream in(text);
  std::string dims, rest;
  char x1 = 0, x2 = 0;
  if (!(in >> s.kind >> dims) || (in >> rest) ||
      (s.kind != "nn" && s.kind != "nt" && s.kind != "tn"))
    throw Error("shape '" + text + "' is not 'nn|nt|tn MxNxK'");
  std::istringstream d(dims);
  long long m = 0, n = 0, k = 0;
  if (!(d >> m >> x1 >> n >> x2 >> k) || x1 != 'x' || x2 != 'x' || m <= 0 || n <= 0 || k <= 0 ||
      (d >> rest))
    throw Error("shape '" + text + "' is not 'nn|nt|tn MxNxK'");
  s.m = m;
  s.n = n;
  s.k = k;
  return s;
}

double parse_gflops(const std::string& text) {
  const std::optional<double> v = parse_whole_double(text);
  if (v && *v >= 0) return *v;
  throw Error("'" + text + "' is not a GFLOP/s value");
}

bool same_device(const GemmCacheEntry& a, const GemmCacheEntry& b) {
  return a.device == b.device && a.vendor == b.vendor && a.driver == b.driver &&
         a.clblast == b.clblast;
}

void load_winners(DeviceState& st, const DeviceInfo& info,
                  const std::vector<GemmCacheEntry>& entries) {
  st.winners.clear();
  const GemmCacheEntry key = gemm_cache_key(info);
  for (const auto& e : entries)
    if (same_device(e, key)) st.winners[e.shape] = e.config;
}

}  // namespace

std::mutex& clblast_mutex() {
  static std::mutex m;
  return m;
}

const GemmTuning& gemm_tuning_for(const DeviceInfo& device) {
  static const GemmTuning defaults{"clblast-defaults", {}};
  static const GemmTuning pocl = pocl_cpu();
  const bool is_pocl = lower(device.platform_name).find("portable computing") != std::string::npos ||
                       lower(device.opencl_version).find("pocl") != std::string::npos;
  if (is_pocl && (device.type & CL_DEVICE_TYPE_CPU)) return pocl;
  return defaults;
}

std::string clblast_version() {
  return std::to_string(CLBLAST_VERSION_MAJOR) + "." + std::to_string(CLBLAST_VERSION_MINOR) +
         "." + std::to_string(CLBLAST_VERSION_PATCH);
}

GemmCacheEntry gemm_cache_key(const DeviceInfo& device) {
  GemmCacheEntry e;
  e.device = device.name;
  e.vendor = device.vendor;
  e.driver = device.driver_version;
  e.clblast = clblast_version();
  return e;
}

std::string gemm_tuning_cache_path() {
  if (const char* p = std::getenv("NOVA_TUNING_CACHE"); p && *p) return p;
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x)
    return std::string(x) + "/nova/gemm-tuning.tsv";
  if (const char* h = std::getenv("HOME"); h && *h)
    return std::string(h) + "/.cache/nova/gemm-tuning.tsv";
  return "";
}

std::vector<GemmCacheEntry> read_gemm_cache(const std::string& path) {
  std::vector<GemmCacheEntry> out;
  std::error_code ec;
  if (path.empty() || !std::filesystem::exists(path, ec)) return out;
  if (!std::filesystem::is_regular_file(path, ec))
    throw Error("GEMM tuning cache " + path + ": not a regular file");
  std::ifstream in(path);
  if (!in) throw Error("GEMM tuning cache " + path + ": cannot be read");
  std::string line;
  size_t number = 0;
  bool header = false;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty() || line[0] == '#') continue;
    const std::string where = "GEMM tuning cache " + path + ", line " + std::to_string(number);
    if (!header) {
      if (line != kMagic)
        throw Error(where + ": not a nova GEMM tuning cache (expected the line 'nova-gemm-tuning<TAB>1'; "
                    "delete the file or run `nova tune` to rewrite it)");
      header = true;
      continue;
    }
    const auto f = split_tabs(line);
    if (f.size() != 8)
      throw Error(where + ": expected 8 tab-separated fields, found " + std::to_string(f.size()) +
                  " (delete the file or run `nova tune` to rewrite it)");
    GemmCacheEntry e;
    try {
      if (!unescape(f[0], e.device) || !unescape(f[1], e.vendor) || !unescape(f[2], e.driver) ||
          !unescape(f[3], e.clblast))
        throw Error("bad escape sequence");
      e.shape = parse_shape(f[4]);
      e.config = GemmConfig::parse(f[5]);
      e.default_gflops = parse_gflops(f[6]);
      e.tuned_gflops = parse_gflops(f[7]);
    } catch (const Error& err) {
      throw Error(where + ": " + err.what() + " (delete the file or run `nova tune` to rewrite it)");
    }
    out.push_back(std::move(e));
  }
  if (!header && number > 0)
    throw Error("GEMM tuning cache " + path + ": no 'nova-gemm-tuning<TAB>1' header line");
  return out;
}

void write_gemm_cache(const std::string& path, const std::vector<GemmCacheEntry>& entries) {
  namespace fs = std::filesystem;
  if (path.empty()) throw Error("no GEMM tuning cache path (set NOVA_TUNING_CACHE or HOME)");
  const fs::path target(path);
  std::error_code ec;
  if (target.has_parent_path()) {
    fs::create_directories(target.parent_path(), ec);
    if (ec) throw Error("cannot create the folder of " + path + ": " + ec.message());
  }
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::trunc);
    if (!out) throw Error("cannot write " + tmp);
    out << "# nova GEMM tuning cache: the fastest GEMM configuration per device and shape class,\n"
           "# each checked against a float64 host reference (written by `nova tune`).\n"
           "# device\tvendor\tdriver\tclblast\tshape (kind MxNxK)\tconfig\tdefault GFLOP/s\ttuned GFLOP/s\n"
        << kMagic << "\n";
    char buf[64];
    for (const auto& e : entries) {
      out << escape(e.device) << '\t' << escape(e.vendor) << '\t' << escape(e.driver) << '\t'
          << escape(e.clblast) << '\t' << e.shape.str() << '\t' << e.config.str();
      std::snprintf(buf, sizeof buf, "\t%.3f\t%.3f\n", e.default_gflops, e.tuned_gflops);
      out << buf;
    }
    out.flush();
    if (!out) {
      out.close();
      fs::remove(tmp, ec);
      throw Error("writing " + tmp + " failed");
    }
  }
  fs::rename(tmp, target, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw Error("cannot rename " + tmp + " to " + path + ": " + ec.message());
  }
}

void merge_gemm_cache(const std::string& path, const std::vector<GemmCacheEntry>& entries) {
  std::vector<GemmCacheEntry> all;
  try {
    all = read_gemm_cache(path);
  } catch (const Error& e) {  // a corrupt cache is replaced, and said so
    std::cerr << "nova: warning: " << e.what() << "; replacing it\n";
  }
  for (const auto& e : entries) {
    auto same = [&](const GemmCacheEntry& o) { return same_device(o, e) && o.shape == e.shape; };
    all.erase(std::remove_if(all.begin(), all.end(), same), all.end());
    all.push_back(e);
  }
  write_gemm_cache(path, all);
}

// Called with clblast_mutex() held.
void apply_clblast_config(Runtime& rt, const GemmConfig& cfg) {
  std::lock_guard<std::recursive_mutex> lock(state_mutex);
  DeviceState& st = states[rt.device()];
  const std::string sig = cfg.str();
  if (st.applied == sig) return;
  const GemmTuning& table = gemm_tuning_for(rt.info());
  Params params = st.library_xgemm;
  if (auto it = table.overrides.find("Xgemm"); it != table.overrides.end())
    for (const auto& [k, v] : it->second) params[k] = v;
  for (const auto& [k, v] : cfg.params) {
    if (!cfg.params.empty() && !params.empty() && !params.count(k))
      throw Error("GEMM configuration '" + sig + "': CLBlast's Xgemm has no parameter " + k);
    params[k] = v;
  }
  if (params.empty()) {  // nothing known and nothing asked: CLBlast's defaults are in force
    st.applied = sig;
    return;
  }
  st.applied.clear();
  const auto status = clblast::OverrideParameters(rt.device(), "Xgemm",
                                                  clblast::Precision::kSingle, params);
  if (status != clblast::StatusCode::kSuccess)
    throw Error("CLBlast rejected the Xgemm parameters of '" + sig + "' (status " +
                std::to_string(static_cast<int>(status)) + ")");
  st.applied = sig;
}

void configure_gemm(Runtime& rt) {
  std::lock_guard<std::mutex> clblast_lock(clblast_mutex());
  std::lock_guard<std::recursive_mutex> lock(state_mutex);
  if (states.count(rt.device())) return;
  DeviceState& st = states[rt.device()];
  Params lib;
  if (clblast::RetrieveParameters(rt.device(), "Xgemm", clblast::Precision::kSingle, lib) ==
      clblast::StatusCode::kSuccess)
    st.library_xgemm = lib;
  for (const auto& [kernel, params] : gemm_tuning_for(rt.info()).overrides) {
    const auto status = clblast::OverrideParameters(rt.device(), kernel,
                                                    clblast::Precision::kSingle, params);
    if (status != clblast::StatusCode::kSuccess)
      throw Error("CLBlast rejected the tuning of " + kernel + " (status " +
                      std::to_string(static_cast<int>(status)) + ")",
                  kExitInternal);
  }
  st.applied = GemmConfig{}.str();
  load_winners(st, rt.info(), read_gemm_cache_or_warn(gemm_tuning_cache_path(), std::cerr));
}

std::vector<GemmCacheEntry> read_gemm_cache_or_warn(const std::string& path, std::ostream& warn) {
  try {
    return read_gemm_cache(path);
  } catch (const Error& e) {
    warn << "nova: warning: " << e.what() << "; GEMMs use the built-in tuning table\n";
  } catch (const std::exception& e) {  // e.g. a file system error
    warn << "nova: warning: GEMM tuning cache " << path << ": " << e.what()
         << "; GEMMs use the built-in tuning table\n";
  }
  return {};
}

size_t reload_gemm_cache(Runtime& rt, const std::string& path) {
  configure_gemm(rt);
  std::lock_guard<std::recursive_mutex> lock(state_mutex);
  const auto entries = read_gemm_cache(path);
  DeviceState& st = states[rt.device()];
  load_winners(st, rt.info(), entries);
  return st.winners.size();
}

std::optional<GemmConfig> tuned_gemm_config(Runtime& rt, const GemmArgs& g) {
  const auto shape = gemm_shape_class(g);
  if (!shape) return std::nullopt;
  configure_gemm(rt);
  std::lock_guard<std::recursive_mutex> lock(state_mutex);
  const auto& winners = states[rt.device()].winners;
  if (winners.empty()) return std::nullopt;
  if (auto it = winners.find(*shape); it != winners.end()) return it->second;
  // The nearest tuned long dimension within a factor of 4 (same kind and widths).
  const GemmConfig* best = nullptr;
  double best_dist = 2.01;
  for (const auto& [s, cfg] : winners) {
    if (s.kind != shape->kind) continue;
    const bool tn = s.kind == "tn";
    if (tn ? (s.m != shape->m || s.n != shape->n) : (s.n != shape->n || s.k != shape->k)) continue;
    const double d = std::fabs(std::log2(double(tn ? s.k : s.m)) - std::log2(double(tn ? shape->k : shape->m)));
    if (d < best_dist) {
      best_dist = d;
      best = &cfg;
    }
  }
  if (best) return *best;
  return std::nullopt;
}

}  // namespace nova

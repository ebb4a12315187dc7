// GEMM tuning: configurations and shape classes, the per-device cache of measured winners
// (`nova tune`), and the winner a GEMM runs with.
#include "nova/tuning/gemm_tuning.hpp"

#include <clblast.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <mutex>
#include <sstream>
#include <unistd.h>

#include "runtime/parse_number.hpp"

namespace nova {
namespace {

// The cache's winners per device, loaded once (load_gemm_cache) or on request
// (reload_gemm_cache).
std::mutex winners_mutex;
std::map<cl_device_id, std::map<GemmShapeClass, GemmConfig>> winners_by_device;

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

std::map<GemmShapeClass, GemmConfig> device_winners(const DeviceInfo& info,
                                                    const std::vector<GemmCacheEntry>& entries) {
  std::map<GemmShapeClass, GemmConfig> winners;
  const GemmCacheEntry key = gemm_cache_key(info);
  for (const auto& e : entries)
    if (same_device(e, key)) winners[e.shape] = e.config;
  return winners;
}

}  // namespace

std::string GemmConfig::str() const {
  std::string s = provider;
  for (const auto& [k, v] : params) s += " " + k + "=" + std::to_string(v);
  return s;
}

GemmConfig GemmConfig::parse(const std::string& text) {
  std::istringstream in(text);
  GemmConfig c;
  if (!(in >> c.provider) ||
      (c.provider != "clblast" && c.provider != "kernels" && c.provider != "blocked" &&
       c.provider != "host"))
    throw Error("'" + text + "' is no GEMM configuration (clblast|kernels|blocked|host KEY=VALUE...)");
  for (std::string item; in >> item;) {
    const size_t eq = item.find('=');
    const std::optional<unsigned long long> v =
        eq == std::string::npos || eq == 0 ? std::nullopt : parse_whole_unsigned(item.substr(eq + 1));
    if (!v || item[eq + 1] == '-') throw Error("'" + text + "': '" + item + "' is not KEY=unsigned integer");
    c.params[item.substr(0, eq)] = static_cast<size_t>(*v);
  }
  if ((c.provider == "kernels" || c.provider == "host") && !c.params.empty())
    throw Error("'" + text + "': the " + c.provider + " provider takes no parameters");
  if (c.provider == "blocked") blocked_gemm_params(c);  // validates
  return c;
}

BlockedGemmParams blocked_gemm_params(const GemmConfig& c) {
  BlockedGemmParams b;
  for (const auto& [key, v] : c.params) {
    if (key == "RM") b.rm = v;
    else if (key == "VN") b.vn = v;
    else if (key == "KC") b.kc = v;
    else if (key == "TA") b.ta = v;
    else throw Error("GEMM configuration '" + c.str() + "': unknown parameter " + key);
  }
  if (b.rm < 1 || b.rm > 16 || b.vn < 1 || b.vn > 4 || b.ta > 1)
    throw Error("GEMM configuration '" + c.str() + "': RM must be 1..16, VN 1..4, TA 0 or 1");
  return b;
}

std::optional<GemmShapeClass> gemm_shape_class(const GemmArgs& g) {
  if (g.trans_a && g.trans_b) return std::nullopt;
  size_t long_dim = g.trans_a ? g.k : g.m;
  if (long_dim < kGemmTunedMinRows) return std::nullopt;
  size_t p = 1;
  while (p * 2 <= long_dim) p *= 2;
  const char* kind = g.trans_a ? "tn" : g.trans_b ? "nt" : "nn";
  return GemmShapeClass{kind, g.trans_a ? g.m : p, g.n, g.trans_a ? p : g.k};
}

std::string GemmShapeClass::str() const {
  return kind + " " + std::to_string(m) + "x" + std::to_string(n) + "x" + std::to_string(k);
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

void load_gemm_cache(Runtime& rt) {
  std::lock_guard<std::mutex> lock(winners_mutex);
  if (winners_by_device.count(rt.device())) return;
  winners_by_device[rt.device()] =
      device_winners(rt.info(), read_gemm_cache_or_warn(gemm_tuning_cache_path(), std::cerr));
}

size_t reload_gemm_cache(Runtime& rt, const std::string& path) {
  const auto entries = read_gemm_cache(path);
  std::lock_guard<std::mutex> lock(winners_mutex);
  auto& winners = winners_by_device[rt.device()];
  winners = device_winners(rt.info(), entries);
  return winners.size();
}

std::optional<GemmConfig> tuned_gemm_config(Runtime& rt, const GemmArgs& g) {
  const auto shape = gemm_shape_class(g);
  if (!shape) return std::nullopt;
  load_gemm_cache(rt);
  std::lock_guard<std::mutex> lock(winners_mutex);
  const auto& winners = winners_by_device[rt.device()];
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

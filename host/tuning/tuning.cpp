// The kernel tuning database: each family's parameters as -D defines, and the per-device table.
#include "nova/tuning/tuning.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdlib>
#include <sstream>
#include <utility>

namespace nova {
namespace {

// CLBlast's Xgemm parameter names, in the order of its tuner.
constexpr std::pair<const char*, size_t XgemmParams::*> kXgemmFields[] = {
    {"GEMMK", &XgemmParams::gemmk}, {"KREG", &XgemmParams::kreg},   {"STRM", &XgemmParams::strm},
    {"STRN", &XgemmParams::strn},   {"SA", &XgemmParams::sa},       {"SB", &XgemmParams::sb},
    {"MWG", &XgemmParams::mwg},     {"NWG", &XgemmParams::nwg},     {"KWG", &XgemmParams::kwg},
    {"MDIMC", &XgemmParams::mdimc}, {"NDIMC", &XgemmParams::ndimc}, {"MDIMA", &XgemmParams::mdima},
    {"NDIMB", &XgemmParams::ndimb}, {"KWI", &XgemmParams::kwi},     {"VWM", &XgemmParams::vwm},
    {"VWN", &XgemmParams::vwn}};

std::string define(const char* name, size_t value) {
  return std::string("-D") + name + "=" + std::to_string(value);
}

DeviceTuning pocl_cpu() {
  DeviceTuning t;
  t.name = "pocl-cpu";
  // Measured on PoCL 3.1 (AVX-512): 12-18 GFLOP/s forward and 17-21 for the weight gradient,
  // against 11.5 / 2.8 with the defaults (a 6x win on dW = X^T dY).
  t.xgemm = XgemmParams{.gemmk = 0, .kreg = 1, .strm = 0, .strn = 0, .sa = 1, .sb = 1,
                        .mwg = 64, .nwg = 64, .kwg = 16, .mdimc = 8, .ndimc = 8, .mdima = 8,
                        .ndimb = 8, .kwi = 2, .vwm = 8, .vwn = 8};
  // Always the indirect path: one compiled program instead of two (a cold PoCL compile costs
  // 10-35 s per CLBlast program), and MLP layers are large anyway.
  t.xgemm_min_indirect_size = 0;
  // A host function reading whole rows: 65536 x 256 in about 6 ms on 2 cores, where the
  // kernel's work-items, each reading 32 bytes of every 1 KiB row, took about 30.
  t.bias_grad = BiasGradWalk::Host;
  return t;
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

}  // namespace

std::unordered_map<std::string, size_t> XgemmParams::params() const {
  std::unordered_map<std::string, size_t> p;
  for (const auto& [name, field] : kXgemmFields) p[name] = this->*field;
  return p;
}

std::string XgemmParams::to_defines() const {
  std::string s;
  for (const auto& [name, field] : kXgemmFields) s += (s.empty() ? "" : " ") + define(name, this->*field);
  return s;
}

std::string BlockedGemmParams::to_defines() const {
  return define("GEMM_RM", rm) + " " + define("GEMM_VN", vn);
}

std::string RenderParams::to_defines() const {
  std::ostringstream s;
  s << "-DNERFS=" << nerfs << " -DRGB_SIGMOID=" << rgb_sigmoid
    << " -DBLEND_SIGMOID=" << blend_sigmoid << " -DHARD_BLEND=" << hard_blend;
  const RenderParams plain;
  if (blend_eps != plain.blend_eps) {
    char buf[32];
    const auto r = std::to_chars(buf, buf + sizeof buf, blend_eps);
    s << " -DBLEND_EPS=" << std::string(buf, r.ptr) << "f";
  }
  if (alpha_full_sum) s << " -DALPHA_FULL_SUM=1";
  if (no_blend) s << " -DNO_BLEND=1";
  if (nerf_depth) s << " -DNERF_DEPTH=1";
  return s.str();
}

std::string HashGridParams::to_defines() const {
  return define("HG_DIMS", dims) + " " + define("HG_FEATURES", features) +
         (extend ? " -DHG_EXTEND=1" : "");
}

std::string ActivationParams::to_defines() const { return "-DACT=" + std::to_string(act); }

std::string ActivationParams::gemm_epilogue_defines() const {
  return " -DGEMM_BIAS_ACT=" + std::to_string(act);
}

std::string PackParams::to_defines() const { return define("PACK_BLOCK", block); }

PackParams pack_params() { return PackParams{}; }

HashBackward hash_backward_choice(const DeviceInfo& d) {
  const char* env = std::getenv("NOVA_HASH_BACKWARD");
  const std::string want = env ? env : "";
  if (want == "ordered") return HashBackward::Ordered;
  if (want == "atomic") {
    if (!d.int64_atomics)
      throw Error("NOVA_HASH_BACKWARD=atomic: device '" + d.name + "' has no cl_khr_int64_base_atomics", kExitUsage);
    return HashBackward::Atomic;
  }
  if (!want.empty() && want != "auto")
    throw Error("NOVA_HASH_BACKWARD='" + want + "': expected auto, ordered or atomic", kExitUsage);
  // A CPU's few cores are busy with the networks and levels of the ordered backward, which
  // measured faster there (docs/performance.md); a GPU needs parallelism over rows.
  return d.int64_atomics && !(d.type & CL_DEVICE_TYPE_CPU) ? HashBackward::Atomic : HashBackward::Ordered;
}

BiasGradWalk bias_grad_walk(const DeviceInfo& d) {
  const char* env = std::getenv("NOVA_BIAS_GRAD");
  const std::string want = env ? env : "";
  const bool native = d.runs_native_calls();
  if (want == "host") {
    if (!native)
      throw Error("NOVA_BIAS_GRAD=host: device '" + d.name + "' runs no native kernels (host functions)", kExitUsage);
    return BiasGradWalk::Host;
  }
  if (want == "row-walk") return BiasGradWalk::Rows;
  if (want == "strided") return BiasGradWalk::Strided;
  if (!want.empty() && want != "auto")
    throw Error("NOVA_BIAS_GRAD='" + want + "': expected auto, host, row-walk or strided", kExitUsage);
  const BiasGradWalk entry = device_tuning(d).bias_grad;
  return entry == BiasGradWalk::Host && !native ? BiasGradWalk::Rows : entry;
}

ArenaLayout arena_layout(const DeviceInfo& d) {
  const char* env = std::getenv("NOVA_ARENA");
  const std::string want = env ? env : "";
  if (want == "sub-buffers") return ArenaLayout::SubBuffers;
  if (want == "separate") return ArenaLayout::Separate;
  if (!want.empty() && want != "auto")
    throw Error("NOVA_ARENA='" + want + "': expected auto, sub-buffers or separate", kExitUsage);
  const bool nvidia = lower(d.platform_name).find("nvidia") != std::string::npos ||
                      lower(d.vendor).find("nvidia") != std::string::npos;
  return nvidia ? ArenaLayout::Separate : ArenaLayout::SubBuffers;
}

const DeviceTuning& device_tuning(const DeviceInfo& device) {
  static const DeviceTuning defaults{"clblast-defaults", std::nullopt, std::nullopt};
  static const DeviceTuning pocl = pocl_cpu();
  const bool is_pocl = lower(device.platform_name).find("portable computing") != std::string::npos ||
                       lower(device.opencl_version).find("pocl") != std::string::npos;
  if (is_pocl && (device.type & CL_DEVICE_TYPE_CPU)) return pocl;
  return defaults;
}

}  // namespace nova

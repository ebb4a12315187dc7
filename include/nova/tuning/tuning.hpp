#pragma once
// The kernel tuning database, after CLBlast's Database: per kernel family a typed parameter
// set that yields the family's build options (its -D defines), and per device the values
// measured to beat the defaults. The ops ask it for their defines; none of them spells a -D.
// GEMM's per-device cache of measured winners and the search behind `nova tune` are in
// gemm_tuning.hpp.
//
// Two kinds of parameters live here: tuned ones (CLBlast's Xgemm, the blocked GEMM's tile and
// work-group, the packing block, the hash grid's backward), which the table or the GEMM cache
// may set per device, and the switches an op's
// configuration sets (render conventions, hash-grid dimensions, activations), which are the
// same on every device but are defines of the same programs, so they are spelled in one place.
// A define's text is part of the program cache key: an entry that spells it differently
// builds another program.
#include <cstddef>
#include <optional>
#include <string>
#include <unordered_map>

#include "nova/runtime/runtime.hpp"

namespace nova {

// ---- GEMM ----------------------------------------------------------------------------------
// CLBlast's Xgemm kernel parameters (CLBlast's names; CLBlast turns them into the kernel's
// #defines itself, nova hands them over with clblast::OverrideParameters).
struct XgemmParams {
  size_t gemmk = 0, kreg = 0, strm = 0, strn = 0, sa = 0, sb = 0, mwg = 0, nwg = 0, kwg = 0,
         mdimc = 0, ndimc = 0, mdima = 0, ndimb = 0, kwi = 0, vwm = 0, vwn = 0;
  // {"GEMMK": gemmk, "KREG": kreg, ...}: what clblast::OverrideParameters takes.
  std::unordered_map<std::string, size_t> params() const;
  std::string to_defines() const;  // "-DGEMMK=0 -DKREG=1 ... -DVWN=8", in CLBlast's order
};

// nova's register-blocked kernel (gemm_blk of kernels/gemm.cl): RM x 8 VN blocks of C per
// work-item, the reduction split in KC chunks (0: no split), A^T packed first (TA = 1). RM and
// VN are defines; KC and TA shape the launch. The cache spells it "blocked RM=6 VN=2 KC=1024".
struct BlockedGemmParams {
  size_t rm = 6, vn = 2, kc = 0, ta = 0;
  std::string to_defines() const;  // "-DGEMM_RM=6 -DGEMM_VN=2"
};

// ---- the other families ----------------------------------------------------------------------
// kernels/render.cl: NeRF count and compositing conventions (render.hpp's RenderOptions).
struct RenderParams {
  size_t nerfs = 1;
  bool rgb_sigmoid = true, blend_sigmoid = true, hard_blend = false;
  float blend_eps = 1e-6f;
  bool alpha_full_sum = false, no_blend = false, nerf_depth = false;
  // "-DNERFS=1 -DRGB_SIGMOID=1 -DBLEND_SIGMOID=1 -DHARD_BLEND=0"; the conventions beyond
  // nova's own (blend_eps, alpha_full_sum, no_blend, nerf_depth) only when set, so nova's
  // programs keep their options (and source after preprocessing) unchanged.
  std::string to_defines() const;
};

// kernels/hash_encoding.cl: input dimensions, features per level, the extended box.
struct HashGridParams {
  size_t dims = 3, features = 2;
  bool extend = false;
  std::string to_defines() const;  // "-DHG_DIMS=3 -DHG_FEATURES=2" (+ " -DHG_EXTEND=1")
};

// How the hash grid's table gradient is summed; both are bit-reproducible. Ordered: one
// work-item per network and level walks the rows in order (float sums). Atomic: one work-item
// per row and level, fixed-point 64-bit atomics (exact integer sums, rounded to float once),
// needs cl_khr_int64_base_atomics. NOVA_HASH_BACKWARD=auto|ordered|atomic chooses; auto takes
// atomic on devices other than CPUs that have the extension. Error (exit 2) for a bad value
// or atomic on a device without the extension.
enum class HashBackward { Ordered, Atomic };
HashBackward hash_backward_choice(const DeviceInfo& device);

// How bias_act's backward sums the bias gradient and writes dh; all three give the same bits.
// Strided: one work-item per column and part (GPUs). Rows: one work-item per eight columns
// walking the rows in order (bias_act.cl's bias_grad_rows). Host: the same walk as a host
// function on the device's queue (bias_grad_host.cpp; CPU devices with native kernels, for the
// identity and ReLU; other activations take Rows), reading whole rows in order on all cores.
enum class BiasGradWalk { Strided, Rows, Host };
// NOVA_BIAS_GRAD=auto|host|row-walk|strided chooses; auto takes the device's entry, Host only
// where the device runs native kernels (else Rows). Error (exit 2) for a bad value, or host on
// a device without native kernels.
BiasGradWalk bias_grad_walk(const DeviceInfo& device);

// Where an executor's activations, their gradients and the workspaces live. SubBuffers: one
// arena sized by the memory plan, each tensor a sub-buffer at its planned offset (tensors whose
// lifetimes do not meet share memory). Separate: a buffer per tensor, nothing shared. NVIDIA's
// OpenCL driver (580.159, H100) crashed inside clReleaseMemObject when an executor whose
// sub-buffers overlap was destroyed (docs/known-issues.md), so NVIDIA devices take Separate;
// guarded executors (tests) always keep the arena, whose regions never overlap.
enum class ArenaLayout { SubBuffers, Separate };
// NOVA_ARENA=auto|sub-buffers|separate chooses; auto: Separate on NVIDIA platforms, else
// SubBuffers. Error (exit 2) for another value.
ArenaLayout arena_layout(const DeviceInfo& device);

// kernels/bias_act.cl's ACT, and the GEMM epilogue's GEMM_BIAS_ACT (kernels/gemm.cl): the
// activation's number (ops.hpp's Activation).
struct ActivationParams {
  int act = 0;
  std::string to_defines() const;           // "-DACT=1"
  std::string gemm_epilogue_defines() const;  // " -DGEMM_BIAS_ACT=1" (appended to a GEMM's)
};

// kernels/packing.cl: rows per compaction block. Not per device: it sizes the pack op's
// scratch when the graph is built, before any device is asked.
struct PackParams {
  size_t block = 128;
  std::string to_defines() const;  // "-DPACK_BLOCK=128"
};
PackParams pack_params();

// ---- per device --------------------------------------------------------------------------------
// A 2D work-group cap for Launch::run2: at most `items` work-items, at most `items0` along
// dimension 0 (0: the kernel's own limit / no cap).
struct WorkGroupCap {
  size_t items = 0, items0 = 0;
};

// One device's entry: matched on device type and platform; values come from measurements on
// the device class, not guesses. Kernels not named here take the runtime's work-group choice
// (Runtime::work_group_size: up to 256, a multiple of the kernel's preferred granularity).
struct DeviceTuning {
  std::string name;  // shown by `nova devices` and the benchmark
  // CLBlast's Xgemm and GemmRoutine's XGEMM_MIN_INDIRECT_SIZE; none: CLBlast's own database.
  std::optional<XgemmParams> xgemm;
  std::optional<size_t> xgemm_min_indirect_size;
  // gemm_blk: at most 16 column blocks x (64 / that) row blocks, small enough that a CPU
  // device gets many groups to share among its threads.
  WorkGroupCap blocked_gemm_group{64, 16};
  // The bias gradient (with dh) walking rows in order (BiasGradWalk::Rows or Host) instead of
  // a work-item per column and part reading rows `parts` apart: the same sums, in the order a
  // CPU's caches and prefetchers read fastest.
  BiasGradWalk bias_grad = BiasGradWalk::Strided;
};

// The entry for a device ("clblast-defaults": nothing overridden).
const DeviceTuning& device_tuning(const DeviceInfo& device);

}  // namespace nova

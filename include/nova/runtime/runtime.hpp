#pragma once
// The OpenCL runtime: device discovery and choice, one context + one in-order queue per
// Runtime, programs built once per context and cached, RAII buffers, kernel launches.
#include <CL/cl.h>

#include <cstddef>
#include <deque>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "nova/runtime/error.hpp"

namespace nova {

struct DeviceInfo {
  cl_platform_id platform = nullptr;
  cl_device_id device = nullptr;
  int platform_index = 0;
  int device_index = 0;
  std::string platform_name;
  std::string name;
  std::string vendor;
  std::string driver_version;
  std::string opencl_version;  // CL_DEVICE_VERSION, e.g. "OpenCL 1.2 PoCL ..."
  cl_device_type type = 0;
  cl_uint compute_units = 0;
  cl_ulong global_mem_bytes = 0;
  cl_ulong max_alloc_bytes = 0;
  size_t max_work_group_size = 0;
  // CL_DEVICE_MAX_WORK_ITEM_SIZES of dimensions 0 and 1 (no limit until queried).
  size_t max_work_item_sizes[2] = {static_cast<size_t>(-1), static_cast<size_t>(-1)};
  cl_uint base_addr_align_bytes = 0;
  bool fp64 = false;
  bool unified_memory = false;
  bool native_kernels = false;  // CL_EXEC_NATIVE_KERNEL: runs host functions in queue order
  bool int64_atomics = false;   // cl_khr_int64_base_atomics (the hash grid's parallel backward)

  // A CPU that runs host functions in queue order on buffers it shares with the host (the
  // host GEMM provider and the host passes, host/ops/linalg/native_call.hpp).
  bool runs_native_calls() const { return (type & CL_DEVICE_TYPE_CPU) && native_kernels; }
  std::string type_name() const;  // "GPU", "CPU", "ACCELERATOR", ...
  std::string id() const;         // "P:D", the selector form
};

// Every device of every platform. An empty list means no OpenCL platform is installed.
std::vector<DeviceInfo> list_devices();

// Chooses a device: `selector` ("cpu" or "gpu": the first device of that type; "P:D"; or a
// case-insensitive substring of the device or platform name); when empty, the NOVA_DEVICE variable; when that is empty too, the first
// GPU, else the first CPU. Throws Error (exit code 2) naming what was found and what to
// install when nothing matches.
DeviceInfo select_device(const std::string& selector = "");

class Buffer {
 public:
  Buffer() = default;
  Buffer(cl_mem mem, size_t bytes) : mem_(mem), bytes_(bytes) {}
  Buffer(const Buffer&) = delete;
  Buffer& operator=(const Buffer&) = delete;
  Buffer(Buffer&& o) noexcept { *this = std::move(o); }
  Buffer& operator=(Buffer&& o) noexcept;
  ~Buffer();

  cl_mem get() const { return mem_; }
  size_t bytes() const { return bytes_; }
  explicit operator bool() const { return mem_ != nullptr; }

 private:
  cl_mem mem_ = nullptr;
  size_t bytes_ = 0;
};

class Runtime;

// Host <-> device copies made through a Runtime since the last reset: a blocking read stalls
// the host until the queue drains, so the training step's hot path must keep its reads small
// (counts, scalars), never a per-sample buffer.
struct TransferStats {
  size_t reads = 0, read_bytes = 0, largest_read = 0;
  size_t writes = 0, write_bytes = 0, largest_write = 0;
};

// Commands put on a runtime's queue, by kind: on a GPU each costs microseconds of launch
// overhead whatever its size, so their number per training step bounds a small step's pace.
struct CommandCounts {
  size_t kernels = 0;  // this runtime's own kernels
  size_t library = 0;  // calls into CLBlast (each one or more kernels of its own, not seen here)
  size_t host = 0;     // host functions on the queue (the host GEMM, the host bias gradient)
  size_t memory = 0;   // fills, writes and reads
  size_t total() const { return kernels + library + host + memory; }
};

// One kind of kernel launch, recorded when Runtime::record_launches is on: the kernel, the
// problem size of each dimension (before rounding up) and the work-group size chosen for it.
// Lets a test prove that every kernel ran at sizes that are no multiple of its work-group.
struct LaunchRecord {
  std::string family, name;
  size_t dims = 1;
  size_t size[2] = {1, 1};
  size_t local[2] = {1, 1};
  auto key() const {
    return std::make_tuple(family, name, dims, size[0], size[1], local[0], local[1]);
  }
  bool operator<(const LaunchRecord& o) const { return key() < o.key(); }
};

// A kernel launch with its arguments set in order: launch(rt, k).arg(a).arg(b).run(n).
class Launch {
 public:
  Launch(Runtime& rt, cl_kernel kernel) : rt_(rt), kernel_(kernel) {}
  Launch& arg(cl_mem m);
  Launch& arg(const Buffer& b) { return arg(b.get()); }
  Launch& arg(float v);
  Launch& arg(int v);
  Launch& arg(unsigned v);
  Launch& arg(const cl_float4& v);
  Launch& local_floats(size_t n);  // __local float[n]
  // 1D over n items; the work-group size comes from the device and kernel (capped at
  // `max_group` when given), the global size is rounded up, and kernels guard with their own
  // count. A CPU device runs each work-group on one thread: a kernel of a few long
  // work-items (a serial loop each) caps its group at 1 so that the threads share them.
  void run(size_t n, size_t max_group = 0);
  // 2D over (n0, n1), dimension 0 fastest. `max_group` caps the work-group (0: the kernel's
  // own limit) and `max0` its extent along dimension 0 (0: no cap), e.g. to leave a CPU
  // device many groups to share among its threads.
  void run2(size_t n0, size_t n1, size_t max_group = 0, size_t max0 = 0);

 private:
  Runtime& rt_;
  cl_kernel kernel_;
  cl_uint index_ = 0;
};

class Runtime {
 public:
  explicit Runtime(const DeviceInfo& device, bool profiling = true);
  ~Runtime();
  Runtime(const Runtime&) = delete;
  Runtime& operator=(const Runtime&) = delete;

  const DeviceInfo& info() const { return info_; }
  cl_context context() const { return context_; }
  cl_device_id device() const { return info_.device; }
  cl_command_queue queue() const { return queue_; }
  cl_command_queue* queue_ptr() { return &queue_; }
  bool profiling() const { return profiling_; }
  bool is_cpu() const { return (info_.type & CL_DEVICE_TYPE_CPU) != 0; }

  // The kernel `name` from the embedded family `family`, built with `options`; programs are
  // built once per (family, options) and kernels created once per name.
  cl_kernel kernel(const std::string& family, const std::string& name,
                   const std::string& options = "");
  // Builds (or finds) the program of a family without creating a kernel: for warm-ups.
  void prepare(const std::string& family, const std::string& options = "");
  Launch launch(const std::string& family, const std::string& name,
                const std::string& options = "") {
    return Launch(*this, kernel(family, name, options));
  }
  // Work-group size for a 1D launch of `kernel` (queried, never assumed).
  size_t work_group_size(cl_kernel kernel);

  // Off by default (no cost). When on, every distinct (kernel, sizes, work-group) launch of
  // this runtime's own kernels is kept; CLBlast's launches are not seen.
  void record_launches(bool on) { record_launches_ = on; }
  const std::set<LaunchRecord>& launches() const { return launches_; }
  // Every launch of this runtime's own kernels: counted, and recorded when record_launches is on.
  void note_launch(cl_kernel kernel, size_t dims, const size_t* size, const size_t* local);

  // Every command enqueued since the last reset (always counted: an increment each).
  const CommandCounts& commands() const { return commands_; }
  void reset_commands() { commands_ = {}; }
  void count_library_call() { ++commands_.library; }
  void count_host_call() { ++commands_.host; }

  Buffer alloc(size_t bytes);
  // A view of [offset, offset + bytes) of `parent`; offset must honour base_addr_align_bytes.
  Buffer sub_buffer(const Buffer& parent, size_t offset, size_t bytes);
  const TransferStats& transfers() const { return transfers_; }
  void reset_transfers() { transfers_ = {}; }
  // Blocking: returns when the data is on the device, i.e. after everything queued before.
  void upload(cl_mem dst, const void* src, size_t bytes, size_t offset = 0);
  // Returns at once: the bytes are copied to a staging block that the queue writes from in
  // order, so the host never waits for the device to drain. A block is freed once its write
  // has completed, found by the runtime's own calls (the next upload_async, a blocking
  // transfer, finish), never from an event callback: a callback that freed the block and
  // released its event could leave the NVIDIA driver spinning in a later wait.
  void upload_async(cl_mem dst, const void* src, size_t bytes, size_t offset = 0);
  // Staging blocks of upload_async not freed yet (at most kMaxStagedUploads).
  size_t staged_uploads() const { return staged_.size(); }
  static constexpr size_t kMaxStagedUploads = 256;
  // dst[i] = value for the floats of [offset, offset + bytes); queued, non-blocking.
  void fill_floats(cl_mem dst, float value, size_t bytes, size_t offset = 0);
  void download(cl_mem src, void* dst, size_t bytes, size_t offset = 0);
  void fill_zero(cl_mem dst, size_t bytes, size_t offset = 0);
  void finish();

  // Convenience for tests and tools.
  Buffer upload_floats(const std::vector<float>& v);
  std::vector<float> download_floats(cl_mem src, size_t count);

 private:
  cl_program build_program(const std::string& family, const std::string& options);
  // Frees the staging blocks whose writes have completed, oldest first, then waits for the
  // oldest until at most `keep` remain (0: every one; after finish or a blocking transfer on
  // the in-order queue they have all completed, so that waits for nothing).
  void free_staged_uploads(size_t keep);
  struct StagedUpload {
    cl_event done = nullptr;
    std::unique_ptr<unsigned char[]> block;
  };

  DeviceInfo info_;
  cl_context context_ = nullptr;
  cl_command_queue queue_ = nullptr;
  bool profiling_ = false;
  std::map<std::pair<std::string, std::string>, cl_program> programs_;
  std::map<std::tuple<std::string, std::string, std::string>, cl_kernel> kernels_;
  std::map<cl_kernel, size_t> work_group_sizes_;
  std::map<cl_kernel, std::pair<std::string, std::string>> kernel_names_;  // family, name
  bool record_launches_ = false;
  TransferStats transfers_;
  CommandCounts commands_;
  std::set<LaunchRecord> launches_;
  std::deque<StagedUpload> staged_;  // oldest first; one thread uses a Runtime
};

// Throws ClError when status is not CL_SUCCESS.
void cl_check(cl_int status, const char* call);

}  // namespace nova

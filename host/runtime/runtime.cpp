// Context, queue, program cache and buffers of one device.
#include <algorithm>
#include <cstdlib>
#include <cstring>

#include "nova/runtime/kernel_sources.hpp"
#include "nova/runtime/runtime.hpp"

namespace nova {

void cl_check(cl_int status, const char* call) {
  if (status != CL_SUCCESS) throw ClError(call, status);
}

Buffer& Buffer::operator=(Buffer&& o) noexcept {
  if (this != &o) {
    if (mem_) clReleaseMemObject(mem_);
    mem_ = std::exchange(o.mem_, nullptr);
    bytes_ = std::exchange(o.bytes_, 0);
  }
  return *this;
}

Buffer::~Buffer() {
  if (mem_) clReleaseMemObject(mem_);
}

Runtime::Runtime(const DeviceInfo& device, bool profiling) : info_(device), profiling_(profiling) {
  cl_int st = CL_SUCCESS;
  const cl_context_properties props[] = {
      CL_CONTEXT_PLATFORM, reinterpret_cast<cl_context_properties>(info_.platform), 0};
  context_ = clCreateContext(props, 1, &info_.device, nullptr, nullptr, &st);
  cl_check(st, "clCreateContext");
  // One in-order queue: ops run in graph order without explicit events between them.
  queue_ = clCreateCommandQueue(context_, info_.device,
                                profiling ? CL_QUEUE_PROFILING_ENABLE : 0, &st);
  cl_check(st, "clCreateCommandQueue");
}

Runtime::~Runtime() {
  if (queue_) clFinish(queue_);
  free_staged_uploads(0);
  for (auto& [key, k] : kernels_) clReleaseKernel(k);
  for (auto& [key, p] : programs_)
    if (p) clReleaseProgram(p);
  if (queue_) clReleaseCommandQueue(queue_);
  if (context_) clReleaseContext(context_);
}

cl_program Runtime::build_program(const std::string& family, const std::string& options) {
  const auto& sources = kernel_sources();
  const auto it = std::find_if(sources.begin(), sources.end(),
                               [&](const KernelSource& s) { return s.family == family; });
  const auto prelude = std::find_if(sources.begin(), sources.end(),
                                    [](const KernelSource& s) { return s.family == kKernelPrelude; });
  if (it == sources.end() || it == prelude || prelude == sources.end())
    throw Error("no embedded kernel family '" + family + "'", kExitInternal);
  // The prelude, then the family from its own line 1 (so build logs name the family's lines).
  static constexpr std::string_view kLine = "\n#line 1\n";
  const char* texts[3] = {prelude->source.data(), kLine.data(), it->source.data()};
  const size_t lengths[3] = {prelude->source.size(), kLine.size(), it->source.size()};
  cl_int st = CL_SUCCESS;
  cl_program program = clCreateProgramWithSource(context_, 3, texts, lengths, &st);
  cl_check(st, "clCreateProgramWithSource");
  const std::string opts = "-cl-std=CL1.2 " + options;
  st = clBuildProgram(program, 1, &info_.device, opts.c_str(), nullptr, nullptr);
  if (st != CL_SUCCESS) {
    size_t n = 0;
    clGetProgramBuildInfo(program, info_.device, CL_PROGRAM_BUILD_LOG, 0, nullptr, &n);
    std::string log(n, '\0');
    clGetProgramBuildInfo(program, info_.device, CL_PROGRAM_BUILD_LOG, n, log.data(), nullptr);
    clReleaseProgram(program);
    throw Error("kernels/" + family + ".cl failed to build (" + cl_status_name(st) +
                    ") with options '" + opts + "':\n" + log,
                kExitInternal);
  }
  return program;
}

cl_kernel Runtime::kernel(const std::string& family, const std::string& name,
                          const std::string& options) {
  const auto key = std::make_tuple(family, name, options);
  if (auto it = kernels_.find(key); it != kernels_.end()) return it->second;
  prepare(family, options);
  cl_int st = CL_SUCCESS;
  cl_kernel k = clCreateKernel(programs_[{family, options}], name.c_str(), &st);
  if (st != CL_SUCCESS)
    throw Error("kernel '" + name + "' not found in kernels/" + family + ".cl (" +
                    cl_status_name(st) + ")",
                kExitInternal);
  kernels_[key] = k;
  kernel_names_[k] = {family, name};
  return k;
}

void Runtime::prepare(const std::string& family, const std::string& options) {
  auto& program = programs_[{family, options}];
  if (!program) program = build_program(family, options);
}

size_t Runtime::work_group_size(cl_kernel kernel) {
  if (auto it = work_group_sizes_.find(kernel); it != work_group_sizes_.end()) return it->second;
  size_t max_wg = 0, multiple = 1;
  cl_check(clGetKernelWorkGroupInfo(kernel, info_.device, CL_KERNEL_WORK_GROUP_SIZE,
                                    sizeof(max_wg), &max_wg, nullptr),
           "clGetKernelWorkGroupInfo");
  clGetKernelWorkGroupInfo(kernel, info_.device, CL_KERNEL_PREFERRED_WORK_GROUP_SIZE_MULTIPLE,
                           sizeof(multiple), &multiple, nullptr);
  // 256 keeps GPUs occupied without exhausting registers; never more than the kernel allows,
  // and a multiple of the preferred granularity where possible.
  size_t wg = std::min<size_t>({256, std::max<size_t>(1, max_wg), info_.max_work_item_sizes[0]});
  if (multiple > 1 && wg >= multiple) wg -= wg % multiple;
  wg = std::max<size_t>(1, wg);
  work_group_sizes_[kernel] = wg;
  return wg;
}

Buffer Runtime::alloc(size_t bytes) {
  cl_int st = CL_SUCCESS;
  cl_mem m = nullptr;
  if (is_cpu()) {
    // A CPU device's buffers live in memory nova allocates (CL_MEM_USE_HOST_PTR, which PoCL
    // uses in place), so that host code run in queue order (the host BLAS's native kernel,
    // gemm_host.cpp) can address them and their sub-buffers through CL_MEM_HOST_PTR. The
    // memory is freed when the runtime releases the buffer.
    constexpr size_t kAlign = 4096;
    const size_t size = (std::max<size_t>(bytes, 4) + kAlign - 1) / kAlign * kAlign;
    void* host = std::aligned_alloc(kAlign, size);
    if (!host)
      throw Error("cannot allocate " + std::to_string(bytes) + " bytes of host memory for " + info_.name,
                  kExitInternal);
    m = clCreateBuffer(context_, CL_MEM_READ_WRITE | CL_MEM_USE_HOST_PTR, size, host, &st);
    if (st == CL_SUCCESS)
      st = clSetMemObjectDestructorCallback(m, [](cl_mem, void* p) { std::free(p); }, host);
    else
      std::free(host);
  } else {
    m = clCreateBuffer(context_, CL_MEM_READ_WRITE, std::max<size_t>(bytes, 4), nullptr, &st);
  }
  if (st != CL_SUCCESS)
    throw Error("cannot allocate " + std::to_string(bytes) + " bytes on " + info_.name + ": " +
                    cl_status_name(st),
                kExitInternal);
  return Buffer(m, bytes);
}

Buffer Runtime::sub_buffer(const Buffer& parent, size_t offset, size_t bytes) {
  cl_buffer_region region{offset, std::max<size_t>(bytes, 4)};
  cl_int st = CL_SUCCESS;
  cl_mem m = clCreateSubBuffer(parent.get(), CL_MEM_READ_WRITE, CL_BUFFER_CREATE_TYPE_REGION,
                               &region, &st);
  cl_check(st, "clCreateSubBuffer");
  return Buffer(m, bytes);
}

namespace {
// One copy of `bytes` into the counters of TransferStats.
void tally(size_t& count, size_t& total, size_t& largest, size_t bytes) {
  ++count;
  total += bytes;
  largest = std::max(largest, bytes);
}
}  // namespace

void Runtime::upload(cl_mem dst, const void* src, size_t bytes, size_t offset) {
  if (bytes == 0) return;
  tally(transfers_.writes, transfers_.write_bytes, transfers_.largest_write, bytes);
  ++commands_.memory;
  cl_check(clEnqueueWriteBuffer(queue_, dst, CL_TRUE, offset, bytes, src, 0, nullptr, nullptr),
           "clEnqueueWriteBuffer");
  free_staged_uploads(0);
}

void Runtime::free_staged_uploads(size_t keep) {
  while (!staged_.empty()) {
    StagedUpload& s = staged_.front();
    cl_int status = CL_QUEUED;
    if (clGetEventInfo(s.done, CL_EVENT_COMMAND_EXECUTION_STATUS, sizeof(status), &status, nullptr) != CL_SUCCESS)
      status = CL_COMPLETE;  // an event that cannot be read is waited for below
    // Queued, submitted or running; a negative status is a write that failed: over as well.
    if (status > CL_COMPLETE) {
      if (staged_.size() <= keep) break;
      clWaitForEvents(1, &s.done);
    }
    clReleaseEvent(s.done);
    staged_.pop_front();
  }
}

void Runtime::upload_async(cl_mem dst, const void* src, size_t bytes, size_t offset) {
  if (bytes == 0) return;
  free_staged_uploads(kMaxStagedUploads - 1);
  tally(transfers_.writes, transfers_.write_bytes, transfers_.largest_write, bytes);
  StagedUpload s;
  s.block = std::make_unique<unsigned char[]>(bytes);
  std::memcpy(s.block.get(), src, bytes);
  ++commands_.memory;
  cl_check(clEnqueueWriteBuffer(queue_, dst, CL_FALSE, offset, bytes, s.block.get(), 0, nullptr, &s.done),
           "clEnqueueWriteBuffer");
  staged_.push_back(std::move(s));
}

void Runtime::fill_floats(cl_mem dst, float value, size_t bytes, size_t offset) {
  if (bytes == 0) return;
  ++commands_.memory;
  cl_check(clEnqueueFillBuffer(queue_, dst, &value, sizeof(value), offset, bytes, 0, nullptr, nullptr),
           "clEnqueueFillBuffer");
}

void Runtime::download(cl_mem src, void* dst, size_t bytes, size_t offset) {
  if (bytes == 0) return;
  tally(transfers_.reads, transfers_.read_bytes, transfers_.largest_read, bytes);
  ++commands_.memory;
  cl_check(clEnqueueReadBuffer(queue_, src, CL_TRUE, offset, bytes, dst, 0, nullptr, nullptr),
           "clEnqueueReadBuffer");
  free_staged_uploads(0);
}

void Runtime::fill_zero(cl_mem dst, size_t bytes, size_t offset) {
  if (bytes == 0) return;
  const float zero = 0.0f;
  ++commands_.memory;
  cl_check(clEnqueueFillBuffer(queue_, dst, &zero, sizeof(zero), offset, bytes, 0, nullptr,
                               nullptr),
           "clEnqueueFillBuffer");
}

void Runtime::finish() {
  cl_check(clFinish(queue_), "clFinish");
  free_staged_uploads(0);
}

Buffer Runtime::upload_floats(const std::vector<float>& v) {
  Buffer b = alloc(v.size() * sizeof(float));
  upload(b.get(), v.data(), v.size() * sizeof(float));
  return b;
}

std::vector<float> Runtime::download_floats(cl_mem src, size_t count) {
  std::vector<float> v(count);
  download(src, v.data(), count * sizeof(float));
  return v;
}

void Runtime::note_launch(cl_kernel kernel, size_t dims, const size_t* size, const size_t* local) {
  ++commands_.kernels;
  if (!record_launches_) return;
  LaunchRecord r;
  if (auto it = kernel_names_.find(kernel); it != kernel_names_.end())
    std::tie(r.family, r.name) = it->second;
  r.dims = dims;
  for (size_t d = 0; d < dims && d < 2; ++d) {
    r.size[d] = size[d];
    r.local[d] = local[d];
  }
  launches_.insert(std::move(r));
}

// ---- Launch ----------------------------------------------------------------------------------

Launch& Launch::arg(cl_mem m) {
  cl_check(clSetKernelArg(kernel_, index_++, sizeof(cl_mem), &m), "clSetKernelArg(mem)");
  return *this;
}
Launch& Launch::arg(float v) {
  cl_check(clSetKernelArg(kernel_, index_++, sizeof(float), &v), "clSetKernelArg(float)");
  return *this;
}
Launch& Launch::arg(int v) {
  cl_check(clSetKernelArg(kernel_, index_++, sizeof(int), &v), "clSetKernelArg(int)");
  return *this;
}
Launch& Launch::arg(unsigned v) {
  cl_check(clSetKernelArg(kernel_, index_++, sizeof(unsigned), &v), "clSetKernelArg(uint)");
  return *this;
}
Launch& Launch::arg(const cl_float4& v) {
  cl_check(clSetKernelArg(kernel_, index_++, sizeof(cl_float4), &v), "clSetKernelArg(float4)");
  return *this;
}
Launch& Launch::local_floats(size_t n) {
  cl_check(clSetKernelArg(kernel_, index_++, n * sizeof(float), nullptr), "clSetKernelArg(local)");
  return *this;
}

void Launch::run(size_t n, size_t max_group) {
  if (n == 0) return;
  const size_t own = rt_.work_group_size(kernel_);
  const size_t wg = max_group ? std::min(max_group, own) : own;
  const size_t global = (n + wg - 1) / wg * wg;
  rt_.note_launch(kernel_, 1, &n, &wg);
  cl_check(clEnqueueNDRangeKernel(rt_.queue(), kernel_, 1, nullptr, &global, &wg, 0, nullptr,
                                  nullptr),
           "clEnqueueNDRangeKernel");
}

void Launch::run2(size_t n0, size_t n1, size_t max_group, size_t max0) {
  if (n0 == 0 || n1 == 0) return;
  // Dimension 0 takes as much of the work-group as it can use: it is the contiguous one.
  // Powers of two within the kernel's work-group size and the device's per-dimension limits.
  const size_t own = rt_.work_group_size(kernel_);
  const size_t wg = max_group ? std::min(max_group, own) : own;
  const size_t* max_items = rt_.info().max_work_item_sizes;
  const size_t cap0 = max0 ? std::min(max0, max_items[0]) : max_items[0];
  size_t l0 = 1;
  while (l0 * 2 <= wg && l0 * 2 <= cap0 && l0 < n0) l0 *= 2;
  size_t l1 = 1;
  while (l0 * l1 * 2 <= wg && l1 * 2 <= max_items[1] && l1 < n1) l1 *= 2;
  const size_t local[2] = {l0, l1};
  const size_t global[2] = {(n0 + l0 - 1) / l0 * l0, (n1 + l1 - 1) / l1 * l1};
  const size_t size[2] = {n0, n1};
  rt_.note_launch(kernel_, 2, size, local);
  cl_check(clEnqueueNDRangeKernel(rt_.queue(), kernel_, 2, nullptr, global, local, 0, nullptr,
                                  nullptr),
           "clEnqueueNDRangeKernel");
}

}  // namespace nova

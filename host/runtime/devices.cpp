// Device discovery and the --device / NOVA_DEVICE choice.
#include <CL/cl.h>
#include <CL/cl_ext.h>

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <sstream>

#include "nova/runtime/runtime.hpp"

namespace nova {
namespace {

std::string device_string(cl_device_id d, cl_device_info what) {
  size_t n = 0;
  if (clGetDeviceInfo(d, what, 0, nullptr, &n) != CL_SUCCESS || n == 0) return {};
  std::string s(n, '\0');
  clGetDeviceInfo(d, what, n, s.data(), nullptr);
  while (!s.empty() && (s.back() == '\0' || s.back() == ' ')) s.pop_back();
  return s;
}

template <typename T>
T device_value(cl_device_id d, cl_device_info what) {
  T v{};
  clGetDeviceInfo(d, what, sizeof(T), &v, nullptr);
  return v;
}

std::string platform_string(cl_platform_id p, cl_platform_info what) {
  size_t n = 0;
  if (clGetPlatformInfo(p, what, 0, nullptr, &n) != CL_SUCCESS || n == 0) return {};
  std::string s(n, '\0');
  clGetPlatformInfo(p, what, n, s.data(), nullptr);
  while (!s.empty() && s.back() == '\0') s.pop_back();
  return s;
}

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

const char* kInstallHint =
    "install an OpenCL driver: on Debian `apt-get install pocl-opencl-icd ocl-icd-libopencl1` "
    "(CPU), or your GPU vendor's ICD";

std::string found_summary(const std::vector<DeviceInfo>& all) {
  std::ostringstream s;
  for (size_t i = 0; i < all.size(); ++i)
    s << (i ? ", " : "") << all[i].id() << " " << all[i].name << " (" << all[i].type_name()
      << ")";
  return s.str();
}

}  // namespace

std::string DeviceInfo::type_name() const {
  if (type & CL_DEVICE_TYPE_GPU) return "GPU";
  if (type & CL_DEVICE_TYPE_CPU) return "CPU";
  if (type & CL_DEVICE_TYPE_ACCELERATOR) return "ACCELERATOR";
  return "OTHER";
}

std::string DeviceInfo::id() const {
  return std::to_string(platform_index) + ":" + std::to_string(device_index);
}

std::vector<DeviceInfo> list_devices() {
  cl_uint np = 0;
  cl_int st = clGetPlatformIDs(0, nullptr, &np);
  // The ICD loader answers CL_PLATFORM_NOT_FOUND_KHR when no driver is registered.
  if (st == CL_PLATFORM_NOT_FOUND_KHR || np == 0) return {};
  cl_check(st, "clGetPlatformIDs");
  std::vector<cl_platform_id> platforms(np);
  cl_check(clGetPlatformIDs(np, platforms.data(), nullptr), "clGetPlatformIDs");

  std::vector<DeviceInfo> out;
  for (cl_uint p = 0; p < np; ++p) {
    cl_uint nd = 0;
    if (clGetDeviceIDs(platforms[p], CL_DEVICE_TYPE_ALL, 0, nullptr, &nd) != CL_SUCCESS) continue;
    std::vector<cl_device_id> devices(nd);
    clGetDeviceIDs(platforms[p], CL_DEVICE_TYPE_ALL, nd, devices.data(), nullptr);
    for (cl_uint d = 0; d < nd; ++d) {
      DeviceInfo info;
      info.platform = platforms[p];
      info.device = devices[d];
      info.platform_index = static_cast<int>(p);
      info.device_index = static_cast<int>(d);
      info.platform_name = platform_string(platforms[p], CL_PLATFORM_NAME);
      info.name = device_string(devices[d], CL_DEVICE_NAME);
      info.vendor = device_string(devices[d], CL_DEVICE_VENDOR);
      info.driver_version = device_string(devices[d], CL_DRIVER_VERSION);
      info.opencl_version = device_string(devices[d], CL_DEVICE_VERSION);
      info.type = device_value<cl_device_type>(devices[d], CL_DEVICE_TYPE);
      info.compute_units = device_value<cl_uint>(devices[d], CL_DEVICE_MAX_COMPUTE_UNITS);
      info.global_mem_bytes = device_value<cl_ulong>(devices[d], CL_DEVICE_GLOBAL_MEM_SIZE);
      info.max_alloc_bytes = device_value<cl_ulong>(devices[d], CL_DEVICE_MAX_MEM_ALLOC_SIZE);
      info.max_work_group_size = device_value<size_t>(devices[d], CL_DEVICE_MAX_WORK_GROUP_SIZE);
      // Per-dimension limits (at least 3 dimensions in OpenCL 1.2): a launch must honour them
      // as well as the work-group size.
      const cl_uint dims = device_value<cl_uint>(devices[d], CL_DEVICE_MAX_WORK_ITEM_DIMENSIONS);
      std::vector<size_t> sizes(std::max<cl_uint>(dims, 3), 0);
      if (clGetDeviceInfo(devices[d], CL_DEVICE_MAX_WORK_ITEM_SIZES, sizes.size() * sizeof(size_t),
                          sizes.data(), nullptr) == CL_SUCCESS)
        for (int k = 0; k < 2; ++k)
          if (sizes[k] > 0) info.max_work_item_sizes[k] = sizes[k];
      info.base_addr_align_bytes =
          device_value<cl_uint>(devices[d], CL_DEVICE_MEM_BASE_ADDR_ALIGN) / 8;
      info.fp64 = device_value<cl_device_fp_config>(devices[d], CL_DEVICE_DOUBLE_FP_CONFIG) != 0;
      info.unified_memory = device_value<cl_bool>(devices[d], CL_DEVICE_HOST_UNIFIED_MEMORY);
      info.native_kernels =
          (device_value<cl_device_exec_capabilities>(devices[d], CL_DEVICE_EXECUTION_CAPABILITIES) &
           CL_EXEC_NATIVE_KERNEL) != 0;
      info.int64_atomics = device_string(devices[d], CL_DEVICE_EXTENSIONS).find("cl_khr_int64_base_atomics") !=
                           std::string::npos;
      out.push_back(std::move(info));
    }
  }
  return out;
}

DeviceInfo select_device(const std::string& selector_arg) {
  std::string selector = selector_arg;
  std::string source = "--device";
  if (selector.empty()) {
    if (const char* env = std::getenv("NOVA_DEVICE"); env && *env) {
      selector = env;
      source = "NOVA_DEVICE";
    }
  }
  const auto all = list_devices();
  if (all.empty())
    throw Error(std::string("no OpenCL platform found; ") + kInstallHint);

  if (selector.empty()) {
    for (const auto& d : all)
      if (d.type & CL_DEVICE_TYPE_GPU) return d;
    for (const auto& d : all)
      if (d.type & CL_DEVICE_TYPE_CPU) return d;
    return all.front();
  }

  // "cpu" / "gpu" select by type (the first of that type); "P:D" by index; anything else is a
  // name substring.
  if (const auto type = lower(selector); type == "cpu" || type == "gpu") {
    const cl_device_type want = type == "cpu" ? CL_DEVICE_TYPE_CPU : CL_DEVICE_TYPE_GPU;
    for (const auto& d : all)
      if (d.type & want) return d;
    throw Error(source + " '" + selector + "': this machine has no " + type + " OpenCL device; found: " +
                found_summary(all) + " (see `nova devices`)");
  }
  const auto colon = selector.find(':');
  if (colon != std::string::npos &&
      std::all_of(selector.begin(), selector.end(),
                  [](unsigned char c) { return std::isdigit(c) || c == ':'; })) {
    for (const auto& d : all)
      if (d.id() == selector) return d;
  } else {
    const auto needle = lower(selector);
    for (const auto& d : all)
      if (lower(d.name).find(needle) != std::string::npos ||
          lower(d.platform_name).find(needle) != std::string::npos)
        return d;
  }
  throw Error(source + " '" + selector + "' matches no OpenCL device; found: " +
              found_summary(all) + " (see `nova devices`)");
}

}  // namespace nova

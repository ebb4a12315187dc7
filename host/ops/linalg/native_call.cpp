#include "ops/linalg/native_call.hpp"

#include <string>

namespace nova::detail {

float* host_address(cl_mem m, const char* operand) {
  void* p = nullptr;
  cl_check(clGetMemObjectInfo(m, CL_MEM_HOST_PTR, sizeof(p), &p, nullptr), "clGetMemObjectInfo(CL_MEM_HOST_PTR)");
  if (!p)
    throw Error(std::string("host call: operand ") + operand +
                    " is a buffer without host memory (not from Runtime::alloc on a CPU device)",
                kExitInternal);
  return static_cast<float*>(p);
}

}  // namespace nova::detail

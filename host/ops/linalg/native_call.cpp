#include "ops/linalg/native_call.hpp"

#include <string>
#include <vector>

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

namespace {

void release_all(const std::vector<cl_mem>& held) {
  for (cl_mem m : held) clReleaseMemObject(m);
}

// Called by the runtime once the command has completed (or failed): its buffers may go.
// Releasing a memory object is not among the calls the OpenCL specification rules out in an
// event callback (blocking and context- or queue-creating calls).
void CL_CALLBACK release_held(cl_event, cl_int, void* p) {
  auto* held = static_cast<std::vector<cl_mem>*>(p);
  release_all(*held);
  delete held;
}

}  // namespace

void enqueue_native_bytes(Runtime& rt, void(CL_CALLBACK* fn)(void*), const void* args, size_t bytes,
                          std::initializer_list<cl_mem> buffers, const char* what) {
  auto* held = new std::vector<cl_mem>;
  for (cl_mem m : buffers)
    if (m && clRetainMemObject(m) == CL_SUCCESS) held->push_back(m);
  cl_event done = nullptr;
  rt.count_host_call();
  const cl_int st = clEnqueueNativeKernel(rt.queue(), fn, const_cast<void*>(args), bytes, 0, nullptr,
                                          nullptr, 0, nullptr, &done);
  if (st != CL_SUCCESS) {
    release_all(*held);
    delete held;
    cl_check(st, what);
  }
  const cl_int cb = clSetEventCallback(done, CL_COMPLETE, release_held, held);
  if (cb != CL_SUCCESS) {
    // Without a callback the buffers are released once the command is done, here.
    clWaitForEvents(1, &done);
    release_all(*held);
    delete held;
  }
  clReleaseEvent(done);
  cl_check(cb, "clSetEventCallback(host call)");
}

}  // namespace nova::detail

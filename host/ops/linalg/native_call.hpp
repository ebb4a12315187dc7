#pragma once
// Host functions on a CPU device's queue (clEnqueueNativeKernel): the host GEMM provider and
// the host passes run in queue order with the kernels around them, on the buffers' own memory,
// which a CPU device shares with the host.
#include "nova/runtime/runtime.hpp"

namespace nova::detail {

// The host address of a buffer (or sub-buffer) that Runtime::alloc made on a CPU device;
// Error (internal) for a buffer without host memory. `operand` names it in the message.
float* host_address(cl_mem m, const char* operand);

// Enqueues fn(copy of args) on rt's queue. The runtime copies `args` when the command is
// enqueued, so it may live on the caller's stack. No cl_mem goes through the call's memory
// list: PoCL 3.1 resolves those at enqueue time, without a sub-buffer's origin and before a
// fresh buffer has memory; host addresses come from host_address instead.
template <class Args>
void enqueue_native(Runtime& rt, void(CL_CALLBACK* fn)(void*), const Args& args, const char* what) {
  cl_check(clEnqueueNativeKernel(rt.queue(), fn, const_cast<Args*>(&args), sizeof(Args), 0, nullptr,
                                 nullptr, 0, nullptr, nullptr),
           what);
}

}  // namespace nova::detail

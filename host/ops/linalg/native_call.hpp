#pragma once
// Host functions on a CPU device's queue (clEnqueueNativeKernel): the host GEMM provider and
// the host passes run in queue order with the kernels around them, on the buffers' own memory,
// which a CPU device shares with the host.
#include <initializer_list>

#include "nova/runtime/runtime.hpp"

namespace nova::detail {

// The host address of a buffer (or sub-buffer) that Runtime::alloc made on a CPU device;
// Error (internal) for a buffer without host memory. `operand` names it in the message.
float* host_address(cl_mem m, const char* operand);

// Enqueues fn(copy of `bytes` bytes at `args`) on rt's queue and keeps `buffers` (the ones
// the call addresses; nulls are skipped) alive until the command has completed.
void enqueue_native_bytes(Runtime& rt, void(CL_CALLBACK* fn)(void*), const void* args, size_t bytes,
                          std::initializer_list<cl_mem> buffers, const char* what);

// Enqueues fn(copy of args) on rt's queue. The runtime copies `args` when the command is
// enqueued, so it may live on the caller's stack. No cl_mem goes through the call's memory
// list: PoCL 3.1 resolves those at enqueue time, without a sub-buffer's origin and before a
// fresh buffer has memory; host addresses come from host_address instead. Without a memory
// list the runtime does not know that the command uses the buffers, and a buffer released
// while the command waits in the queue (an error unwinding an Executor mid-step) would have
// its memory freed under the call: `buffers` names every buffer whose memory `args` points
// into, and each is retained until the command completes.
template <class Args>
void enqueue_native(Runtime& rt, void(CL_CALLBACK* fn)(void*), const Args& args,
                    std::initializer_list<cl_mem> buffers, const char* what) {
  enqueue_native_bytes(rt, fn, &args, sizeof(Args), buffers, what);
}

}  // namespace nova::detail

// The "host" GEMM provider of CPU OpenCL devices: the product runs as a native kernel
// (clEnqueueNativeKernel) on the device's own in-order queue and calls the host BLAS's
// cblas_sgemm on the buffers' memory, which a CPU device shares with the host, so nothing is
// copied and the op stays in queue order with the kernels around it. A dense layer's bias and
// ReLU are applied in the same native kernel, row block by row block right after each block's
// product, while it is still in cache. The BLAS is loaded at
// run time (dlopen), so nova_core links OpenCL and CLBlast alone and a machine without an
// optimised BLAS simply has no "host" provider.
#include "ops/linalg/gemm_host.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <mutex>
#include <string>

#include "ops/linalg/native_call.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

// CBLAS's enum values (cblas.h), fixed by the standard interface.
constexpr int kRowMajor = 101, kNoTrans = 111, kTrans = 112;
using SgemmFn = void (*)(int, int, int, int, int, int, float, const float*, int, const float*,
                         int, float, float*, int);

using SetThreadsFn = void (*)(int);
using GetThreadsFn = int (*)();

struct HostBlas {
  SgemmFn sgemm = nullptr;
  std::string library;  // the file that was loaded; empty when none
  // OpenBLAS's thread count, where the library has it (the others keep their own choice).
  SetThreadsFn set_threads = nullptr;
  int threads = 1;  // OpenBLAS's own count at load (OPENBLAS_NUM_THREADS, else the cores)
};

// Optimised BLAS libraries only: the reference BLAS (libblas.so.3) is slower than the
// device's own kernels and is never taken by itself.
const char* const kCandidates[] = {"libopenblas.so.0", "libopenblas.so", "libblis.so.4",
                                   "libblis.so", "libmkl_rt.so.2", "libmkl_rt.so"};

HostBlas load_host_blas() {
  HostBlas h;
  const char* env = std::getenv("NOVA_HOST_BLAS");
  const std::string choice = env ? env : "";
  if (choice == "off") return h;
  std::string why;  // dlopen's or dlsym's error text of the last failed attempt
  auto try_load = [&](const std::string& name) {
    void* lib = dlopen(name.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
      const char* e = dlerror();
      why = e ? e : "dlopen failed";
      return false;
    }
    auto fn = reinterpret_cast<SgemmFn>(dlsym(lib, "cblas_sgemm"));
    if (!fn) {
      why = "no cblas_sgemm in it";
      dlclose(lib);
      return false;
    }
    h.sgemm = fn;
    h.library = name;
    auto set = reinterpret_cast<SetThreadsFn>(dlsym(lib, "openblas_set_num_threads"));
    auto get = reinterpret_cast<GetThreadsFn>(dlsym(lib, "openblas_get_num_threads"));
    if (set && get) {
      h.set_threads = set;
      h.threads = std::max(1, get());
    }
    return true;  // the library stays loaded for the life of the process
  };
  if (!choice.empty()) {
    if (!try_load(choice))
      throw Error("NOVA_HOST_BLAS='" + choice + "': " + why + " (give a BLAS library with cblas_sgemm, or 'off')");
    return h;
  }
  for (const char* name : kCandidates)
    if (try_load(name)) break;
  return h;
}

const HostBlas& host_blas() {
  static const HostBlas h = load_host_blas();
  return h;
}

// What the native kernel receives (copied by the runtime): the operands' host addresses
// (native_call.hpp).
struct HostGemmCall {
  const float* a;
  const float* b;
  float* c;
  SgemmFn sgemm;
  int trans_a, trans_b;
  int m, n, k;
  float alpha, beta;
  int lda, ldb, ldc;
  size_t stride_a, stride_b, stride_c, batch;
  const float* bias;  // null: no epilogue
  size_t stride_bias;
  int relu;
};

// Floats of C per row block of a fused epilogue: 8 MiB, within the shared L3 of current CPUs,
// in few calls (8 for 65536 rows of a 256-wide layer): every BLAS call ends with its threads
// meeting, which on a busy machine can cost a scheduler time slice. With 1 MiB blocks a
// 65536 x 64 layer's forward ran 2.4x slower than a single call and a separate pass beside
// two trainings; with 8 MiB blocks 1.13x faster (docs/performance.md).
constexpr size_t kEpilogueBlockFloats = size_t{1} << 21;

// C rows [r0, r0 + rows) = act(C + bias): bias_act.cl's bias_act_forward, element by element
// (one rounded add, then ReLU as x > 0 ? x : 0, which gives fmax's result for every x).
void bias_act_rows(float* c, int ldc, int r0, int rows, int n, const float* bias, bool relu) {
  for (int r = r0; r < r0 + rows; ++r) {
    float* row = c + static_cast<size_t>(r) * static_cast<size_t>(ldc);
    if (relu)
      for (int j = 0; j < n; ++j) {
        const float v = row[j] + bias[j];
        row[j] = v > 0.0f ? v : 0.0f;
      }
    else
      for (int j = 0; j < n; ++j) row[j] += bias[j];
  }
}

// OpenBLAS threads of one product: all of them only for products that are both wide (middle
// size over 64) and large (m n k >= 2^28), one otherwise. On 2 cores (AMD EPYC) one thread ran
// 8192-65536 rows x 32 and x 64 (forward and weight gradient) 1.06-2.5x faster than two, and
// 8192 x 128 about as fast, where 24576-65536 x 128 and x 256 ran 1.25-1.6x faster on two.
// A multi-threaded call also leaves OpenBLAS's idle threads spinning for a while, taking the
// cores from the kernels that follow: the quick preset's step (64-wide networks, one 91-wide
// colour layer) ran 1.18x faster with every product on one thread (docs/performance.md).
int blas_threads(const HostGemmCall& g) {
  int d[3] = {g.m, g.n, g.k};
  std::sort(d, d + 3);
  const double work = static_cast<double>(g.m) * g.n * g.k;
  return d[1] > 64 && work >= 268435456.0 ? host_blas().threads : 1;
}

// One product at a time: OpenBLAS's thread count is a process-wide setting, and the queues
// of several runtimes (data-parallel ranks as threads) may run their native kernels at once.
std::mutex blas_mutex;

void run_products(const HostGemmCall& g) {
  const int ta = g.trans_a ? kTrans : kNoTrans, tb = g.trans_b ? kTrans : kNoTrans;
  for (size_t i = 0; i < g.batch; ++i) {
    const float* a = g.a + i * g.stride_a;
    const float* b = g.b + i * g.stride_b;
    float* c = g.c + i * g.stride_c;
    if (!g.bias) {
      g.sgemm(kRowMajor, ta, tb, g.m, g.n, g.k, g.alpha, a, g.lda, b, g.ldb, g.beta, c, g.ldc);
      continue;
    }
    // Row blocks of op(A) = A (host_gemm_fuses), each its own call. Where the BLAS's
    // micro-kernel tiles follow the call's row count, rows near a block's edge are summed in
    // another order than one call over all rows would (OpenBLAS's Haswell and Zen kernels;
    // its SkylakeX and Cooperlake kernels give the single call's bits): the same product to
    // float32 rounding (test dense/host_blas_row_blocks), and the same bits run to run.
    const int block = static_cast<int>(std::max<size_t>(64, kEpilogueBlockFloats / static_cast<size_t>(g.n)));
    for (int r0 = 0; r0 < g.m; r0 += block) {
      const int rows = std::min(block, g.m - r0);
      g.sgemm(kRowMajor, ta, tb, rows, g.n, g.k, g.alpha, a + static_cast<size_t>(r0) * g.lda,
              g.lda, b, g.ldb, g.beta, c + static_cast<size_t>(r0) * g.ldc, g.ldc);
      bias_act_rows(c, g.ldc, r0, rows, g.n, g.bias + i * g.stride_bias, g.relu != 0);
    }
  }
}

void CL_CALLBACK run_host_gemm(void* p) {
  const HostGemmCall& g = *static_cast<const HostGemmCall*>(p);
  std::lock_guard<std::mutex> lock(blas_mutex);
  // Set for this product and restored after it: other callers of the same library in this
  // process (the benches call it directly) keep its own count.
  const HostBlas& blas = host_blas();
  const int threads = blas.set_threads ? blas_threads(g) : blas.threads;
  if (threads != blas.threads) blas.set_threads(threads);
  run_products(g);
  if (threads != blas.threads) blas.set_threads(blas.threads);
}

int as_int(size_t v, const char* what) {
  if (v > 0x7fffffffu) throw Error(std::string("host GEMM: ") + what + " exceeds a BLAS int", kExitInternal);
  return static_cast<int>(v);
}

}  // namespace

bool host_gemm_fuses(const GemmArgs& g, Activation act) {
  return !g.trans_a && (act == Activation::Identity || act == Activation::ReLU);
}

bool host_gemm_available(const DeviceInfo& device) {
  return device.runs_native_calls() && host_blas().sgemm;
}

std::string host_blas_library() { return host_blas().library; }

void host_gemm(Runtime& rt, const GemmArgs& g, const GemmEpilogue& epi) {
  if (!host_gemm_available(rt))
    throw Error("GEMM provider 'host': device " + rt.info().name +
                    " cannot run it (it needs a CPU device with native kernels and an optimised "
                    "host BLAS: OpenBLAS, BLIS or MKL; NOVA_HOST_BLAS names one)");
  using detail::host_address;
  const HostGemmCall call{host_address(g.a, "A"), host_address(g.b, "B"), host_address(g.c, "C"),
                          host_blas().sgemm,
                          g.trans_a, g.trans_b,
                          as_int(g.m, "m"), as_int(g.n, "n"), as_int(g.k, "k"),
                          g.alpha, g.beta,
                          as_int(g.lda, "lda"), as_int(g.ldb, "ldb"), as_int(g.ldc, "ldc"),
                          g.stride_a, g.stride_b, g.stride_c, g.batch,
                          epi.bias ? host_address(epi.bias, "bias") : nullptr, epi.stride_bias,
                          epi.act == Activation::ReLU};
  detail::enqueue_native(rt, run_host_gemm, call, {g.a, g.b, g.c, epi.bias}, "clEnqueueNativeKernel(host GEMM)");
}

}  // namespace nova

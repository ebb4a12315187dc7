// bias_act's backward as a host function on a CPU device's queue (BiasGradWalk::Host): the
// sums of kernels/bias_act.cl's bias_grad_rows, bit for bit, walking whole rows in order.
// The kernel gives each work-item eight columns, so every work-item reads 32 bytes of each
// row and the prefetchers see short strided streams; here each thread reads its own
// contiguous share of every row.
#include <algorithm>
#include <thread>
#include <vector>

#include "ops/linalg/layer_parts.hpp"
#include "ops/linalg/native_call.hpp"

namespace nova::detail {
namespace {

struct BiasGradCall {
  const float* y;
  const float* dy;
  float* partial;
  float* dh;  // null: not written
  size_t batches, rows, cols, parts;
  int relu, accumulate_dh, threads;
};

// Columns [c0, c1) of one batch: partial sums s[p][c] over rows r with r % parts == p, in
// increasing r (bias_grad_rows' order, so the same rounding), and dh (+)= g on the way.
// g = dy * act'(y) with act' exactly 0 or 1: one product, exact, so a fused multiply-add the
// compiler may form rounds as the kernel's separate operations do.
void walk_columns(const BiasGradCall& c, size_t batch, size_t c0, size_t c1) {
  const size_t width = c1 - c0;
  std::vector<float> s(c.parts * width, 0.0f);
  const size_t base = batch * c.rows * c.cols;
  for (size_t r = 0; r < c.rows; ++r) {
    const size_t row = base + r * c.cols + c0;
    const float* y = c.y + row;
    const float* dy = c.dy + row;
    float* acc = s.data() + (r % c.parts) * width;
    float* dh = c.dh ? c.dh + row : nullptr;
    for (size_t j = 0; j < width; ++j) {
      const float d = c.relu ? (y[j] > 0.0f ? 1.0f : 0.0f) : 1.0f;
      const float g = dy[j] * d;
      acc[j] += g;
      if (dh) dh[j] = c.accumulate_dh ? dh[j] + g : g;  // dh may be dy: dy[j] is read above
    }
  }
  const size_t batch_cols = c.batches * c.cols;
  for (size_t p = 0; p < c.parts; ++p)
    std::copy_n(s.data() + p * width, width, c.partial + p * batch_cols + batch * c.cols + c0);
}

void CL_CALLBACK run_bias_grad(void* p) {
  const BiasGradCall& c = *static_cast<const BiasGradCall*>(p);
  // Column shares of whole cache lines (16 floats), so no two threads write one line of dh.
  const size_t lines = (c.cols + 15) / 16;
  const size_t threads = std::max<size_t>(1, std::min<size_t>(c.threads, lines));
  const size_t per = (lines + threads - 1) / threads * 16;
  for (size_t b = 0; b < c.batches; ++b) {
    std::vector<std::thread> pool;
    for (size_t t = 1; t < threads && t * per < c.cols; ++t)
      pool.emplace_back([&c, b, t, per] { walk_columns(c, b, t * per, std::min(c.cols, (t + 1) * per)); });
    walk_columns(c, b, 0, std::min(c.cols, per));
    for (std::thread& t : pool) t.join();
  }
}

// Passes under 2^18 elements (a few tenths of a millisecond on one core) stay on one thread:
// starting a second costs tens of microseconds, a noticeable share of so short a pass.
constexpr size_t kThreadedElements = size_t{1} << 18;

}  // namespace

void bias_grad_rows_host(Runtime& rt, Matrix3 s, Activation act, size_t parts, cl_mem y,
                         cl_mem dy, cl_mem partials, cl_mem dh, bool acc_dh) {
  if (act != Activation::Identity && act != Activation::ReLU)
    throw Error("host bias gradient: only the identity and ReLU", kExitInternal);
  if (parts == 0 || parts > 64) throw Error("host bias gradient: parts must be 1..64", kExitInternal);
  const size_t n = s.batch * s.rows * s.cols;
  const int threads = n >= kThreadedElements ? static_cast<int>(std::max<size_t>(1, rt.info().compute_units)) : 1;
  const BiasGradCall call{host_address(y, "y"), host_address(dy, "dy"), host_address(partials, "partials"),
                          dh && n > 0 ? host_address(dh, "dh") : nullptr,
                          s.batch, s.rows, s.cols, parts,
                          act == Activation::ReLU, acc_dh, threads};
  enqueue_native(rt, run_bias_grad, call, {y, dy, partials, dh},
                 "clEnqueueNativeKernel(host bias gradient)");
}

}  // namespace nova::detail

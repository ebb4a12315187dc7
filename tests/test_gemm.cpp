// GEMM through every provider (CLBlast with the device's tuning, nova's own kernels, and the
// host BLAS where the device runs native kernels) against a float64 host reference, for the
// NeRF layer shapes and the transposed products the backward uses.
#include <boost/test/unit_test.hpp>
#include <atomic>
#include <chrono>
#include <cmath>
#include <dlfcn.h>
#include <limits>
#include <thread>

#include "harness.hpp"
#include "nova/ops/linalg/gemm.hpp"

using namespace nova;

namespace {

struct Case {
  bool ta, tb;
  size_t m, n, k, batch;
};

// Checks C = op(A) op(B) + beta C0 elementwise against the float64 product. Bound per element:
// |err| <= 2 k u sum_l |a_il b_lj| + u |c| with u = 2^-24 (Higham's worst-case bound for a
// float32 dot product of length k, doubled for the beta term), so an indexing or layout bug,
// which moves results by O(sum |a b|), cannot pass.
// With `in_arena`, A, B and C are sub-buffers at aligned offsets of one allocation, as the
// executor's arena hands them to ops (a provider must honour a sub-buffer's origin).
void run_case_with(GemmProvider provider, const Case& c, float beta, bool in_arena = false) {
  Runtime& rt = test::runtime();
  set_gemm_provider(rt, provider);
  const size_t rows_a = c.ta ? c.k : c.m, cols_a = c.ta ? c.m : c.k;
  const size_t rows_b = c.tb ? c.n : c.k, cols_b = c.tb ? c.k : c.n;
  const size_t sa = rows_a * cols_a, sb = rows_b * cols_b, sc = c.m * c.n;
  const auto a = test::random_floats(sa * c.batch, -1, 1, 1);
  const auto b = test::random_floats(sb * c.batch, -1, 1, 2);
  const auto c0 = test::random_floats(sc * c.batch, -1, 1, 3);
  Buffer da, db, dc, arena;
  if (in_arena) {
    const size_t align = std::max<size_t>(rt.info().base_addr_align_bytes, 4);
    auto up = [&](size_t floats) { return (floats * sizeof(float) + align - 1) / align * align; };
    const size_t oa = align, ob = oa + up(a.size()) + align, oc = ob + up(b.size()) + align;
    arena = rt.alloc(oc + up(c0.size()) + align);
    rt.fill_zero(arena.get(), arena.bytes());
    da = rt.sub_buffer(arena, oa, a.size() * sizeof(float));
    db = rt.sub_buffer(arena, ob, b.size() * sizeof(float));
    dc = rt.sub_buffer(arena, oc, c0.size() * sizeof(float));
    rt.upload(da.get(), a.data(), a.size() * sizeof(float));
    rt.upload(db.get(), b.data(), b.size() * sizeof(float));
    rt.upload(dc.get(), c0.data(), c0.size() * sizeof(float));
  } else {
    da = rt.upload_floats(a);
    db = rt.upload_floats(b);
    dc = rt.upload_floats(c0);
  }
  GemmArgs g{c.ta, c.tb, c.m, c.n, c.k, 1.0f, da.get(), cols_a, sa, db.get(), cols_b, sb,
             beta, dc.get(), c.n, sc, c.batch};
  Buffer temp;
  if (size_t bytes = gemm_temp_bytes(rt, g)) temp = rt.alloc(bytes);
  gemm(rt, g, temp.get());
  const auto out = rt.download_floats(dc.get(), sc * c.batch);

  const double u = std::numeric_limits<float>::epsilon() / 2;
  double worst = 0;
  for (size_t p = 0; p < c.batch; ++p)
    for (size_t i = 0; i < c.m; ++i)
      for (size_t j = 0; j < c.n; ++j) {
        double ref = 0, mag = 0;
        for (size_t l = 0; l < c.k; ++l) {
          const double x = c.ta ? a[p * sa + l * cols_a + i] : a[p * sa + i * cols_a + l];
          const double y = c.tb ? b[p * sb + j * cols_b + l] : b[p * sb + l * cols_b + j];
          ref += x * y;
          mag += std::fabs(x * y);
        }
        const double cprev = c0[p * sc + i * c.n + j];
        ref += beta * cprev;
        const double bound = 2 * c.k * u * mag + 2 * u * std::fabs(cprev) + 1e-30;
        worst = std::max(worst, std::fabs(out[p * sc + i * c.n + j] - ref) / bound);
      }
  BOOST_TEST(worst <= 1.0, gemm_provider_name(provider) << " m=" << c.m << " n=" << c.n << " k=" << c.k << " ta=" << c.ta
                                << " tb=" << c.tb << " batch=" << c.batch << " beta=" << beta
                                << ": error/bound " << worst);
  if (in_arena) {  // nothing written outside C's sub-buffer
    const auto all = rt.download_floats(arena.get(), arena.bytes() / sizeof(float));
    size_t nonzero = 0;
    for (float v : all) nonzero += v != 0.0f;
    size_t expected = 0;
    for (const auto* v : {&a, &b}) for (float x : *v) expected += x != 0.0f;
    for (float x : out) expected += x != 0.0f;
    BOOST_TEST(nonzero == expected, gemm_provider_name(provider) << ": the arena holds " << nonzero
                                       << " non-zero floats, A, B and C " << expected);
  }
}

std::vector<GemmProvider> providers() {
  std::vector<GemmProvider> p = {GemmProvider::CLBlast, GemmProvider::Kernels};
  if (host_gemm_available(test::runtime())) p.push_back(GemmProvider::Host);
  return p;
}

// Every case through each provider; the device's own choice is restored afterwards.
void run_case(const Case& c, float beta) {
  Runtime& rt = test::runtime();
  const GemmProvider chosen = gemm_provider(rt);
  for (GemmProvider p : providers()) run_case_with(p, c, beta);
  set_gemm_provider(rt, chosen);
}

}  // namespace

BOOST_AUTO_TEST_SUITE(gemm)

// Row counts are deliberately odd (no multiple of any tile or work-group size).
BOOST_AUTO_TEST_CASE(nerf_layer_shapes_forward) {
  run_case({false, false, 97, 256, 63, 1}, 0.0f);   // encoded xyz -> first layer
  run_case({false, false, 97, 256, 256, 1}, 0.0f);  // hidden layers
  run_case({false, false, 97, 256, 319, 1}, 0.0f);  // the skip layer, [input, h]
  run_case({false, false, 97, 4, 256, 1}, 0.0f);    // the rgb + sigma head
}

BOOST_AUTO_TEST_CASE(backward_products) {
  run_case({false, true, 97, 63, 256, 1}, 0.0f);   // dX = dY W^T
  run_case({false, true, 97, 256, 4, 1}, 1.0f);    // dX of the head, accumulating
  run_case({true, false, 63, 256, 97, 1}, 0.0f);   // dW = X^T dY
  run_case({true, false, 256, 4, 97, 1}, 1.0f);    // dW of the head, accumulating
}

BOOST_AUTO_TEST_CASE(batched_networks) {
  run_case({false, false, 53, 32, 19, 3}, 0.0f);
  run_case({false, true, 53, 19, 32, 3}, 1.0f);
  run_case({true, false, 19, 32, 53, 3}, 0.0f);
}

BOOST_AUTO_TEST_CASE(small_and_ragged_shapes) {
  // Fewer rows than one register block, a single column, k = 1, and both-transposed (which
  // the own kernels hand to CLBlast).
  run_case({false, false, 5, 1, 1, 1}, 0.0f);
  run_case({false, false, 3, 7, 5, 2}, 1.0f);
  run_case({true, false, 3, 9, 11, 2}, 1.0f);
  run_case({false, true, 13, 3, 1, 1}, 0.0f);
  run_case({true, true, 9, 5, 7, 1}, 0.0f);
}

// The executor hands ops sub-buffers of one arena: each provider reads and writes at their
// offsets and nowhere else.
BOOST_AUTO_TEST_CASE(sub_buffers_of_an_arena) {
  Runtime& rt = test::runtime();
  const GemmProvider chosen = gemm_provider(rt);
  for (GemmProvider p : providers()) {
    run_case_with(p, {false, false, 37, 16, 9, 1}, 0.0f, true);
    run_case_with(p, {false, true, 37, 9, 16, 2}, 1.0f, true);
    run_case_with(p, {true, false, 9, 16, 37, 2}, 1.0f, true);
  }
  set_gemm_provider(rt, chosen);
}

// The three GEMMs of a layer step at growing sizes, each output a buffer no command has touched
// yet, the buffers released and allocated anew between sizes: a provider that addresses
// memory behind the runtime's back must still find it (checked against float64 sums).
BOOST_AUTO_TEST_CASE(fresh_outputs_and_reused_memory) {
  Runtime& rt = test::runtime();
  const GemmProvider chosen = gemm_provider(rt);
  for (GemmProvider p : providers()) {
    set_gemm_provider(rt, p);
    for (size_t m : {64u, 1031u, 8192u}) {
      const size_t w = 64;
      Buffer x = rt.upload_floats(std::vector<float>(m * w, 0.5f));
      Buffer wt = rt.upload_floats(std::vector<float>(w * w, 0.25f));
      Buffer y = rt.alloc(m * w * sizeof(float)), dx = rt.alloc(m * w * sizeof(float));
      Buffer dw = rt.alloc(w * w * sizeof(float));
      nova::gemm(rt, {false, false, m, w, w, 1.0f, x.get(), w, m * w, wt.get(), w, w * w, 0.0f, y.get(), w, m * w, 1});
      nova::gemm(rt, {false, true, m, w, w, 1.0f, y.get(), w, m * w, wt.get(), w, w * w, 0.0f, dx.get(), w, m * w, 1});
      nova::gemm(rt, {true, false, w, w, m, 1.0f, x.get(), w, m * w, y.get(), w, m * w, 0.0f, dw.get(), w, w * w, 1});
      // y = 64 * 0.5 * 0.25 = 8, dx = 64 * 8 * 0.25 = 128, dw = m * 0.5 * 8 = 4 m: exact in float.
      const auto hy = rt.download_floats(y.get(), m * w), hdx = rt.download_floats(dx.get(), m * w);
      const auto hdw = rt.download_floats(dw.get(), w * w);
      size_t wrong = 0;
      for (float v : hy) wrong += v != 8.0f;
      for (float v : hdx) wrong += v != 128.0f;
      for (float v : hdw) wrong += v != 4.0f * static_cast<float>(m);
      BOOST_TEST(wrong == 0u, gemm_provider_name(p) << " m=" << m << ": " << wrong << " wrong values");
    }
  }
  set_gemm_provider(rt, chosen);
}

// The host BLAS runs where the device is a CPU with native kernels and a BLAS was found; a
// device without them names what is missing instead of computing anything.
// Each provider's commands are counted under their kind (what nova-bench step reports per
// step): a CLBlast call, this runtime's kernels, or one host call; memory commands apart.
BOOST_AUTO_TEST_CASE(commands_are_counted_by_kind) {
  Runtime& rt = test::runtime();
  const GemmProvider chosen = gemm_provider(rt);
  const size_t m = 37, n = 29, k = 45;
  Buffer a = rt.upload_floats(test::random_floats(m * k, -1, 1, 1));
  Buffer b = rt.upload_floats(test::random_floats(k * n, -1, 1, 2));
  Buffer c = rt.alloc(m * n * sizeof(float));
  GemmArgs g{false, false, m, n, k, 1.0f, a.get(), k, m * k, b.get(), n, k * n, 0.0f, c.get(), n, m * n, 1};
  for (GemmProvider p : providers()) {
    set_gemm_provider(rt, p);
    Buffer temp;
    if (size_t bytes = gemm_temp_bytes(rt, g)) temp = rt.alloc(bytes);
    rt.finish();
    rt.reset_commands();
    nova::gemm(rt, g, temp.get());
    rt.fill_zero(temp ? temp.get() : c.get(), sizeof(float));
    rt.finish();
    const CommandCounts counted = rt.commands();
    BOOST_TEST_INFO(gemm_provider_name(p));
    BOOST_TEST(counted.library == (p == GemmProvider::CLBlast ? 1u : 0u));
    BOOST_TEST(counted.host == (p == GemmProvider::Host ? 1u : 0u));
    if (p == GemmProvider::Kernels) BOOST_TEST(counted.kernels >= 1u);
    BOOST_TEST(counted.memory >= 1u);
    BOOST_TEST(counted.total() == counted.kernels + counted.library + counted.host + counted.memory);
  }
  set_gemm_provider(rt, chosen);
}

BOOST_AUTO_TEST_CASE(host_provider_availability) {
  Runtime& rt = test::runtime();
  if (host_gemm_available(rt)) {
    BOOST_TEST(rt.is_cpu());
    BOOST_TEST(!host_blas_library().empty());
    const GemmProvider chosen = gemm_provider(rt);
    set_gemm_provider(rt, GemmProvider::Tuned);
    const GemmArgs untuned{false, false, 4096, 24, 40};  // a shape no cache entry is near
    if (!tuned_gemm_config(rt, untuned))
      BOOST_TEST(gemm_choice(rt, untuned).provider == "host",
                 "without a cache entry a CPU device with a host BLAS takes it");
    set_gemm_provider(rt, chosen);
    return;
  }
  BOOST_TEST_MESSAGE("no host BLAS provider on " << rt.info().name << " (" << host_blas_library() << ")");
  const GemmProvider chosen = gemm_provider(rt);
  // Without a host BLAS and a cache entry the table's CLBlast runs, the weight gradient's long
  // reduction split (at most 32 chunks of at least 2048), other products whole; the forced
  // clblast mode never splits.
  set_gemm_provider(rt, GemmProvider::Tuned);
  const GemmArgs dw{true, false, 48, 40, 65536}, short_k{true, false, 48, 40, 4096}, fwd{false, false, 65536, 40, 48};
  if (!tuned_gemm_config(rt, dw)) BOOST_TEST(gemm_choice(rt, dw).str() == "clblast KC=2048");
  const GemmArgs long_dw{true, false, 48, 40, 1u << 20};
  if (!tuned_gemm_config(rt, long_dw)) BOOST_TEST(gemm_choice(rt, long_dw).str() == "clblast KC=32768");
  if (!tuned_gemm_config(rt, short_k)) BOOST_TEST(gemm_choice(rt, short_k).str() == "clblast");
  if (!tuned_gemm_config(rt, fwd)) BOOST_TEST(gemm_choice(rt, fwd).str() == "clblast");
  set_gemm_provider(rt, GemmProvider::CLBlast);
  BOOST_TEST(gemm_choice(rt, dw).str() == "clblast");
  set_gemm_provider(rt, GemmProvider::Host);
  Buffer a = rt.upload_floats({1.0f}), b = rt.upload_floats({2.0f}), c = rt.upload_floats({0.0f});
  GemmArgs g{false, false, 1, 1, 1, 1.0f, a.get(), 1, 1, b.get(), 1, 1, 0.0f, c.get(), 1, 1, 1};
  BOOST_CHECK_EXCEPTION(nova::gemm(rt, g), Error, [](const Error& e) {
    return std::string(e.what()).find("native kernels") != std::string::npos;
  });
  set_gemm_provider(rt, chosen);
}

// The host provider runs narrow products (middle size <= 64) on one OpenBLAS thread and gives
// the library its own thread count back after each, so other callers in the process (the
// benches call it directly) are not left on one thread. Results are checked above.
BOOST_AUTO_TEST_CASE(host_blas_thread_count_is_restored) {
  Runtime& rt = test::runtime();
  if (!host_gemm_available(rt)) {
    BOOST_TEST_MESSAGE("skipped: the device has no host BLAS provider");
    return;
  }
  void* lib = dlopen(host_blas_library().c_str(), RTLD_NOW | RTLD_NOLOAD);
  auto get = lib ? reinterpret_cast<int (*)()>(dlsym(lib, "openblas_get_num_threads")) : nullptr;
  if (!get) {
    BOOST_TEST_MESSAGE("skipped: " << host_blas_library() << " has no openblas_get_num_threads");
    return;
  }
  const int before = get();
  const GemmProvider chosen = gemm_provider(rt);
  set_gemm_provider(rt, GemmProvider::Host);
  for (size_t width : {size_t{32}, size_t{256}}) {
    Buffer a = rt.upload_floats(std::vector<float>(2048 * width, 0.5f));
    Buffer b = rt.upload_floats(std::vector<float>(width * width, 0.25f));
    Buffer c = rt.alloc(2048 * width * sizeof(float));
    GemmArgs g{false, false, 2048, width, width, 1.0f, a.get(), width, 2048 * width, b.get(), width,
               width * width, 0.0f, c.get(), width, 2048 * width, 1};
    nova::gemm(rt, g);
    const auto out = rt.download_floats(c.get(), 2048 * width);
    BOOST_TEST(out[0] == 0.125f * static_cast<float>(width));
    BOOST_TEST(get() == before, width << " wide: OpenBLAS left on " << get() << " threads, had " << before);
  }
  set_gemm_provider(rt, chosen);
  dlclose(lib);
}

namespace {

// A native kernel that holds the queue until `open` is set (10 s at most, so that a broken
// test cannot hang): the commands behind it wait in the queue while the test releases buffers.
void CL_CALLBACK wait_for_gate(void* p) {
  const auto* open = *static_cast<std::atomic<bool>* const*>(p);
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!open->load() && std::chrono::steady_clock::now() < until)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

// What a released operand's destructor saw: whether C already held the product, i.e.
// whether its memory lived until the GEMM had read it.
struct Freed {
  const float* c;
  size_t count;
  float expected;
  std::atomic<int> destroyed{0}, before_product{0};
};

// C's memory, which a CPU device's buffer keeps on the host (Runtime::alloc).
const float* host_floats(cl_mem m) {
  void* p = nullptr;
  cl_check(clGetMemObjectInfo(m, CL_MEM_HOST_PTR, sizeof(p), &p, nullptr), "clGetMemObjectInfo");
  return static_cast<const float*>(p);
}

void CL_CALLBACK note_destroyed(cl_mem, void* p) {
  auto* f = static_cast<Freed*>(p);
  bool done = true;
  for (size_t i = 0; i < f->count; ++i) done = done && f->c[i] == f->expected;
  f->before_product += !done;
  ++f->destroyed;
}

}  // namespace

// The host provider's native kernel reads its operands through host addresses, out of the
// runtime's sight: operands released while the product still waits in the queue (an error
// unwinding a training step's Executor, which gives back its arena at once) must keep their
// memory until the product has run. A is a sub-buffer, as the executor's arena hands it out:
// its parent holds the memory. A gate holds the queue so that the buffers are certainly
// released before the product starts.
BOOST_AUTO_TEST_CASE(host_gemm_keeps_released_operands_until_done) {
  Runtime& rt = test::runtime();
  if (!host_gemm_available(rt)) {
    BOOST_TEST_MESSAGE("skipped: the device has no host BLAS provider");
    return;
  }
  const GemmProvider chosen = gemm_provider(rt);
  set_gemm_provider(rt, GemmProvider::Host);
  constexpr size_t m = 256, n = 16, k = 32;
  Buffer c = rt.upload_floats(std::vector<float>(m * n, -1.0f));
  Freed freed{host_floats(c.get()), m * n, 0.5f * 0.25f * k + 1.0f};
  {
    const size_t align = std::max<size_t>(rt.info().base_addr_align_bytes, 4);
    Buffer parent = rt.alloc(align + m * k * sizeof(float));
    Buffer a = rt.sub_buffer(parent, align, m * k * sizeof(float));
    rt.upload(a.get(), std::vector<float>(m * k, 0.5f).data(), m * k * sizeof(float));
    Buffer b = rt.upload_floats(std::vector<float>(k * n, 0.25f));
    Buffer bias = rt.upload_floats(std::vector<float>(n, 1.0f));
    for (cl_mem mem : {parent.get(), b.get(), bias.get()})
      BOOST_REQUIRE(clSetMemObjectDestructorCallback(mem, note_destroyed, &freed) == CL_SUCCESS);
    std::atomic<bool> open{false};
    std::atomic<bool>* gate = &open;
    BOOST_REQUIRE(clEnqueueNativeKernel(rt.queue(), wait_for_gate, &gate, sizeof(gate), 0, nullptr, nullptr,
                                        0, nullptr, nullptr) == CL_SUCCESS);
    GemmArgs g{false, false, m, n, k, 1.0f, a.get(), k, m * k, b.get(), n, k * n, 0.0f, c.get(), n, m * n, 1};
    nova::gemm(rt, g, nullptr, GemmEpilogue{bias.get(), 0, Activation::ReLU});
    a = Buffer();
    parent = Buffer();
    b = Buffer();
    bias = Buffer();
    open = true;
    rt.finish();
  }
  BOOST_TEST(freed.destroyed.load() == 3);
  BOOST_TEST(freed.before_product.load() == 0,
             freed.before_product.load() << " of 3 released operands freed before the product had run");
  const auto out = rt.download_floats(c.get(), m * n);
  BOOST_TEST(out.front() == freed.expected);
  BOOST_TEST(out.back() == freed.expected);
  set_gemm_provider(rt, chosen);
}

BOOST_AUTO_TEST_SUITE_END()

// Not a check of results: fills PoCL's on-disk compile cache (every kernel family, every
// activation variant, both CLBlast GEMM programs) before the other suites run in parallel.
// CTest runs it first as the `kernel_cache` fixture.
#include <boost/test/unit_test.hpp>

#include "harness.hpp"
#include "nova/ops/linalg/gemm.hpp"
#include "nova/runtime/kernel_sources.hpp"
#include "nova/render/render_composite.hpp"
#include "nova/tuning/tuning.hpp"

using namespace nova;

BOOST_AUTO_TEST_SUITE(warmup)

BOOST_AUTO_TEST_CASE(compile_every_program) {
  Runtime& rt = test::runtime();
  for (const auto& k : kernel_sources())
    if (k.family != kKernelPrelude) rt.prepare(std::string(k.family));  // the prelude comes with each
  for (int act = 1; act <= 3; ++act) rt.prepare("bias_act", ActivationParams{act}.to_defines());
  // render.cl is built per NeRF count: the counts the suites use, with the default options.
  for (size_t n : {1, 2, 3, 4, 8}) rt.prepare("render", render_program_options(n));
  const std::vector<float> ones(64 * 64, 1.0f);
  Buffer a = rt.upload_floats(ones), b = rt.upload_floats(ones), c = rt.upload_floats(ones);
  for (size_t batch : {1, 2}) {
    GemmArgs g{false, false, 32, 32, 32, 1.0f, a.get(), 32, 1024, b.get(), 32, 1024,
               0.0f, c.get(), 32, 1024, batch};
    gemm(rt, g);
  }
  rt.finish();
  BOOST_TEST(rt.download_floats(c.get(), 1)[0] == 32.0f);
}

BOOST_AUTO_TEST_SUITE_END()

// Device random numbers (random.hpp): Philox4x32-10 against the published known-answer
// vectors (Random123's kat_vectors), the kernels against the host generator, odd sizes,
// counters and streams that change the draw, and the moments of the two distributions.
//
// Tolerances: uniform values are integers times 2^-24 computed identically on host and device
// (exact). Normal values go through log, sqrt, cos and sin, which OpenCL's full-precision
// built-ins give within 4 ulp each: about 1e-6 relative at |x| <= 5.8 (the largest value 24
// bits can make), so 2e-6 + 2e-6 |x| bounds the difference from the float64 reference.
// Moments of 2^18 draws: the standard error of a mean is sd / 512, of a variance about
// sqrt(2) var / 512 (normal) and 0.0023 var (uniform); 6 standard errors make a false failure
// vanishingly rare while a wrong transform (e.g. a lost factor 2 pi) is off by far more.
#include <boost/test/unit_test.hpp>
#include <cmath>

#include "harness.hpp"
#include "nova/graph/executor.hpp"
#include "nova/sampling/random.hpp"
#include "random_reference.hpp"

using namespace nova;

namespace {

std::vector<float> draw(bool normal, size_t n, uint32_t seed, uint32_t stream, uint64_t counter, float scale = 1.0f) {
  Graph g;
  auto c = std::make_shared<DrawCounter>();
  c->value = counter;
  RandomStream rs{seed, stream, c};
  Tensor y = normal ? random_normal(g, "n", Shape{n}, rs, scale) : random_uniform(g, "u", Shape{n}, rs, scale);
  g.keep(y);
  Executor ex(test::runtime(), g);
  ex.forward();
  return ex.get(y);
}

}  // namespace

BOOST_AUTO_TEST_SUITE(device_random)

BOOST_AUTO_TEST_CASE(philox_known_answers) {
  using A4 = std::array<uint32_t, 4>;
  BOOST_TEST((philox4x32_10({0, 0, 0, 0}, {0, 0}) == A4{0x6627e8d5, 0xe169c58d, 0xbc57ac4c, 0x9b00dbd8}));
  BOOST_TEST((philox4x32_10({0xffffffff, 0xffffffff, 0xffffffff, 0xffffffff}, {0xffffffff, 0xffffffff}) ==
              A4{0x408f276d, 0x41c83b0e, 0xa20bc7c6, 0x6d5451fd}));
  BOOST_TEST((philox4x32_10({0x243f6a88, 0x85a308d3, 0x13198a2e, 0x03707344}, {0xa4093822, 0x299f31d0}) ==
              A4{0xd16cfe09, 0x94fdcceb, 0x5001e420, 0x24126ea1}));
}

BOOST_AUTO_TEST_CASE(kernels_match_the_host_generator_at_odd_sizes) {
  const uint64_t counter = (uint64_t{7} << 32) | 12345u;
  for (size_t n : {1, 3, 5, 7, 1031}) {
    const auto u = draw(false, n, 9, 1, counter, 0.5f);
    const auto z = draw(true, n, 9, 2, counter, 0.3f);
    std::vector<double> ru, rz;
    for (size_t i = 0; i < n; ++i) {
      ru.push_back(test::random_reference(false, i, 9, 1, counter, 0.5));
      rz.push_back(test::random_reference(true, i, 9, 2, counter, 0.3));
    }
    test::expect_close(u, ru, 0.0, 0.0, "uniform n=" + std::to_string(n));
    test::expect_close(z, rz, 2e-6, 2e-6, "normal n=" + std::to_string(n));
  }
}

BOOST_AUTO_TEST_CASE(seed_stream_and_counter_each_change_the_draw) {
  const auto base = draw(false, 64, 1, 1, 5);
  BOOST_TEST((draw(false, 64, 1, 1, 5) == base));  // a pure function of its arguments
  for (const auto& other : {draw(false, 64, 2, 1, 5), draw(false, 64, 1, 2, 5), draw(false, 64, 1, 1, 6),
                            draw(false, 64, 1, 1, 5 + (uint64_t{1} << 32))}) {
    size_t same = 0;
    for (size_t i = 0; i < 64; ++i) same += other[i] == base[i];
    BOOST_TEST(same <= 2u);
  }
}

// A slice (rows of 5 columns at offset 7 inside rows of 17: a rank's share of the rays) draws
// exactly the values of those columns of the whole draw, bit for bit.
BOOST_AUTO_TEST_CASE(a_slice_draws_what_the_whole_draws_there) {
  for (bool normal : {false, true}) {
    auto c = std::make_shared<DrawCounter>();
    c->value = 42;
    Graph g;
    Tensor whole = normal ? random_normal(g, "w", Shape{3, 17}, {4, 2, c}) : random_uniform(g, "w", Shape{3, 17}, {4, 2, c});
    RandomStream part{4, 2, c, 17, 7};
    Tensor slice = normal ? random_normal(g, "s", Shape{3, 5}, part) : random_uniform(g, "s", Shape{3, 5}, part);
    g.keep(whole);
    g.keep(slice);
    Executor ex(test::runtime(), g);
    ex.forward();
    const auto w = ex.get(whole), s = ex.get(slice);
    for (size_t r = 0; r < 3; ++r)
      for (size_t k = 0; k < 5; ++k) BOOST_TEST(s[r * 5 + k] == w[r * 17 + 7 + k]);
  }
}

BOOST_AUTO_TEST_CASE(moments) {
  const size_t n = size_t{1} << 18;
  const auto u = draw(false, n, 3, 1, 0), z = draw(true, n, 3, 2, 0);
  double su = 0, suu = 0, sz = 0, szz = 0, lo = 1, hi = 0;
  for (size_t i = 0; i < n; ++i) {
    su += u[i], suu += double(u[i]) * u[i], sz += z[i], szz += double(z[i]) * z[i];
    lo = std::min(lo, double(u[i])), hi = std::max(hi, double(u[i]));
  }
  const double mu = su / n, vu = suu / n - mu * mu, mz = sz / n, vz = szz / n - mz * mz;
  BOOST_TEST(lo >= 0.0);
  BOOST_TEST(hi < 1.0);
  BOOST_TEST(std::fabs(mu - 0.5) < 6 * std::sqrt(1.0 / 12) / 512);
  BOOST_TEST(std::fabs(vu - 1.0 / 12) < 6 * 0.0023 / 12);
  BOOST_TEST(std::fabs(mz) < 6.0 / 512);
  BOOST_TEST(std::fabs(vz - 1.0) < 6 * std::sqrt(2.0) / 512);
}

BOOST_AUTO_TEST_SUITE_END()

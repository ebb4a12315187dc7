// The hash encoding: geometric resolutions, what `extend` changes, central finite differences
// of a table read twice (the gradients accumulate), both table-gradient summations against
// float64 sums with their determinism and exact scaling, and refused settings. Its forward
// against the float64 host reference (dense and hashed levels, clamping, one and several
// networks, 3-D and 4-D inputs, time with fewer cells than space, a box per axis, extended
// levels) and the table gradient's central differences are the op table's hash_encoding
// entry (tests/op_table_grid.cpp), which states their tolerances.
//
// The encoding is linear in the table, so the finite differences carry only float32
// rounding: the harness default (2e-2 of the gradient's scale) holds.
#include <boost/test/unit_test.hpp>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "harness.hpp"
#include "hashgrid_reference.hpp"
#include "nova/runtime/error.hpp"
#include "nova/graph/executor.hpp"
#include "nova/ops/encoding/hash_encoding.hpp"
#include "nova/ops/tensor/tensor_ops.hpp"
#include "nova/loss/terms.hpp"

using namespace nova;
using nova::test::check_gradients;
using nova::test::expect_close;
using nova::test::for_each_vertex;
using nova::test::grid_config;
using nova::test::hash_reference;
using nova::test::OpUnderTest;
using nova::test::random_floats;
using nova::test::test_positions;

namespace {

std::vector<float> run_encoding(const std::vector<float>& pos, const std::vector<float>& table,
                                size_t nets, size_t rows, size_t dims, const HashGridConfig& c) {
  const Shape ts = hash_grid_table_shape(c, nets);
  return test::run_forward(
      [&](Graph& g) {
        Tensor p = g.input("p", nets > 1 ? Shape{nets, rows, dims} : Shape{rows, dims});
        Tensor t = g.input("table", ts);
        return OpUnderTest{{p, t}, hash_encoding(p, t, c)};
      },
      {pos, table});
}

// Runs `body` under each table-gradient summation the device offers (NOVA_HASH_BACKWARD).
template <class Body>
void for_each_backward(Body body) {
  std::vector<std::string> modes{"ordered"};
  if (test::runtime().info().int64_atomics) modes.push_back("atomic");
  for (const std::string& m : modes) {
    setenv("NOVA_HASH_BACKWARD", m.c_str(), 1);
    BOOST_TEST_CONTEXT("backward " << m) { body(m); }
  }
  unsetenv("NOVA_HASH_BACKWARD");
}

// d mse(encoding, target) / d table on the device.
std::vector<float> table_gradient_of(const std::vector<float>& pos, const std::vector<float>& table,
                                     const std::vector<float>& target, size_t rows, size_t dims,
                                     const HashGridConfig& c) {
  Graph g;
  Tensor p = g.input("p", Shape{rows, dims});
  Tensor t = g.input("table", hash_grid_table_shape(c), true);
  Tensor y = g.input("target", Shape{rows, static_cast<size_t>(c.outputs())});
  g.set_loss(mse(hash_encoding(p, t, c), y));
  Executor ex(test::runtime(), g);
  ex.set(p, pos);
  ex.set(t, table);
  ex.set(y, target);
  ex.forward();
  ex.backward();
  return ex.get_grad(t);
}

}  // namespace

BOOST_AUTO_TEST_SUITE(hashgrid)

BOOST_AUTO_TEST_CASE(resolutions_are_geometric) {
  HashGridConfig c;
  c.levels = 5;
  c.min_resolution = 16;
  c.max_resolution = 256;
  const auto r = hash_grid_resolutions(c);
  BOOST_TEST(r == (std::vector<float>{16, 32, 64, 128, 256}), boost::test_tools::per_element());
}

BOOST_AUTO_TEST_CASE(extend_changes_only_points_outside_the_box) {
  // Inside the box both modes read the same vertices with the same weights, bit for bit;
  // outside, hashed levels differ (their own cells) while dense levels still clamp.
  // Levels of 4 and 10 cells are dense (<= 2048 vertices), 25 and 64 hashed.
  HashGridConfig c{.levels = 4, .features = 2, .log2_size = 11, .min_resolution = 4, .max_resolution = 64};
  const size_t rows = 64, L = 4, F = 2;
  std::vector<float> pos = test_positions(rows, 3, 1.0f, 11);
  // Even rows inside the box (test_positions draws +-1.3 b), odd rows beyond x = 1.
  for (size_t r = 0; r < rows; ++r)
    for (size_t d = 0; d < 3; ++d) {
      float& x = pos[r * 3 + d];
      x = std::clamp(x, -1.0f, 1.0f);
      if (d == 0 && r % 2) x = 1.2f + 0.01f * static_cast<float>(r);
    }
  const auto table = random_floats(hash_grid_table_shape(c).numel(), -1, 1, 12);
  const auto clamped = run_encoding(pos, table, 1, rows, 3, c);
  c.extend = true;
  const auto extended = run_encoding(pos, table, 1, rows, 3, c);
  size_t outside_differs = 0;
  for (size_t r = 0; r < rows; ++r)
    for (size_t l = 0; l < L; ++l)
      for (size_t f = 0; f < F; ++f) {
        const size_t i = (r * L + l) * F + f;
        if (r % 2 == 0 || l < 2) BOOST_TEST(clamped[i] == extended[i], "row " << r << " level " << l);
        else outside_differs += clamped[i] != extended[i];
      }
  BOOST_TEST(outside_differs > rows / 2);  // nearly every outside point's hashed features move
}

BOOST_AUTO_TEST_CASE(table_read_twice_accumulates) {
  // Two encodings of one table: its gradient is the sum of both (the second backward adds).
  const HashGridConfig c = grid_config(2, 2, 4, 3, 5);
  const size_t rows = 19;
  for_each_backward([&](const std::string&) {
    check_gradients(
        [&](Graph& g) {
          Tensor p = g.input("p", Shape{rows, 3});
          Tensor q = g.input("q", Shape{rows, 3});
          Tensor t = g.input("table", hash_grid_table_shape(c), true);
          return OpUnderTest{{p, q, t}, concat({hash_encoding(p, t, c), hash_encoding(q, t, c)})};
        },
        {test_positions(rows, 3, 1.0f, 12), random_floats(rows * 3, -1, 1, 13),
         random_floats(hash_grid_table_shape(c).numel(), -1, 1, 14)});
  });
}

// Both backwards against the float64 sum of every contribution, at 1031 rows (ragged for any
// work-group) over a 2^8 table, so that hashed entries collect many rows each. Tolerances:
// the ordered backward sums up to ~rows 2^D terms per entry in float32 (relative error of
// the sum at most n 2^-24 of the sum of |terms|, n ~ 1e3: 1e-4 of the scale of the gradient,
// which is what atol states); the atomic one rounds each term to 2^-k <= 2^-59 rows max|dy|
// and the exact sum to float once (1e-6 relative covers it; the same atol as the ordered).
// Each backward gives the same bits on a second run (fixed order, or exact integer sums),
// and scaling table and targets by 2^-20 scales the gradient by exactly 2^-20 (the fixed-point scale
// follows the gradient's size: nothing underflows).
BOOST_AUTO_TEST_CASE(table_gradient_matches_float64_sums) {
  const HashGridConfig c = grid_config(4, 2, 8, 3, 30);
  const size_t rows = 1031, dims = 3, outs = static_cast<size_t>(c.outputs());
  const auto pos = test_positions(rows, dims, 1.0f, 31);
  const auto table = random_floats(hash_grid_table_shape(c).numel(), -1, 1, 32);
  const auto target = random_floats(rows * outs, -1, 1, 33);
  // The upstream gradient 2 (y - target) / n from the float64 forward, then every
  // contribution w dy summed in float64.
  const auto y = hash_reference(pos, rows, dims, table, c);
  std::vector<double> ref(table.size(), 0.0);
  const uint64_t T = uint64_t{1} << c.log2_size;
  for_each_vertex(pos, rows, dims, c, [&](size_t r, int l, uint64_t row, double w) {
    for (int f = 0; f < c.features; ++f) {
      const size_t o = (r * c.levels + l) * c.features + f;
      ref[(l * T + row) * c.features + f] += w * 2.0 * (y[o] - target[o]) / double(rows * outs);
    }
  });
  double scale = 0;
  for (double v : ref) scale = std::max(scale, std::fabs(v));
  std::vector<float> tiny_table(table), tiny_target(target);
  for (float& v : tiny_table) v = std::ldexp(v, -20);
  for (float& v : tiny_target) v = std::ldexp(v, -20);
  for_each_backward([&](const std::string& mode) {
    const auto g = table_gradient_of(pos, table, target, rows, dims, c);
    expect_close(g, ref, 1e-4 * scale, 1e-6, "table gradient");
    BOOST_TEST(g == table_gradient_of(pos, table, target, rows, dims, c), "second run, same bits");
    // d mse / d table is linear in (encoding - target): scaled by 2^-20 as well.
    const auto tiny = table_gradient_of(pos, tiny_table, tiny_target, rows, dims, c);
    size_t differ = 0;
    for (size_t i = 0; i < g.size(); ++i) differ += tiny[i] != std::ldexp(g[i], -20);
    BOOST_TEST(differ == 0u, mode << ": " << differ << " entries not scaled by exactly 2^-20");
  });
}

BOOST_AUTO_TEST_CASE(unknown_backward_is_refused) {
  setenv("NOVA_HASH_BACKWARD", "fast", 1);
  BOOST_CHECK_THROW(hash_backward_choice(test::runtime().info()), Error);
  unsetenv("NOVA_HASH_BACKWARD");
}

BOOST_AUTO_TEST_CASE(bad_configurations_are_refused) {
  auto refused = [](auto edit) {
    HashGridConfig c;
    edit(c);
    BOOST_CHECK_THROW(validate(c), Error);
  };
  refused([](HashGridConfig& c) { c.levels = 0; });
  refused([](HashGridConfig& c) { c.features = 9; });
  refused([](HashGridConfig& c) { c.log2_size = 30; });
  refused([](HashGridConfig& c) { c.max_resolution = c.min_resolution - 1; });
  refused([](HashGridConfig& c) { c.bound = 0.0f; });
  refused([](HashGridConfig& c) { c.axis_bound[1] = -1.0f; });
  refused([](HashGridConfig& c) { c.time_max_resolution = -1; });
  Graph g;
  Tensor p = g.input("p", Shape{4, 5});
  BOOST_CHECK_THROW(hash_encoding(p, hash_grid_table(g, "t", HashGridConfig{}), HashGridConfig{}),
                    Error);
}

BOOST_AUTO_TEST_SUITE_END()

// Empty-space skipping: the occupancy grid's geometry and update rule, and the packed-sample
// ops (pack_occupied, gather_rows, scatter_rows) with the row-wise ops that run on the live
// rows of a dynamic extent (positional_encoding, concat, linear, bias_act), against float64
// host references and central finite differences; and the sample ranges and open rays that
// early ray termination packs on top of the grids.
//
// Sizes: M = 1009 samples (prime) per batch, so every launch is ragged (the op table's
// packing entry, tests/op_table_grid.cpp, covers each op alone and its launches).
// Tolerances: gather, fill and scatter move floats, so they must be exact. The MLP on packed
// rows is a sum of K = 3 + 3 * 2 * 2 + 3 = 18 float32 products per output, each input within
// 1 of 0 and weights within 1: rtol 1e-5 with atol 1e-5 covers float32 rounding (18 * 6e-8
// relative, plus sin/cos within 4 ulp). Gradients: the harness default (2e-2 of the
// gradient's scale) with pre-activations kept 0.05 away from the ReLU kink.
#include <boost/test/unit_test.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include <memory>

#include "harness.hpp"
#include "packing_reference.hpp"
#include "nova/runtime/error.hpp"
#include "nova/graph/executor.hpp"
#include "nova/sampling/occupancy.hpp"
#include "nova/model/occupancy_estimator.hpp"
#include "nova/ops/linalg/dense.hpp"
#include "nova/ops/tensor/tensor_ops.hpp"
#include "nova/ops/encoding/positional_encoding.hpp"
#include "nova/render/render_composite.hpp"

using namespace nova;
using nova::test::checker_grid;
using nova::test::random_floats;

namespace {

constexpr size_t B = 2, M = 1009, F = 2;  // batches, dense rows, posenc frequencies
constexpr size_t D = 3, E = D * (1 + 2 * F) + D, H = 4;  // input, encoded + raw, hidden

std::shared_ptr<PackSelect> two_grid_select() {
  auto s = std::make_shared<PackSelect>();
  s->grids = std::make_shared<std::vector<OccupancyGrid>>(
      std::vector<OccupancyGrid>{checker_grid(4, 0), checker_grid(4, 1)});
  s->grid_of_batch = {0, 1};
  return s;
}

// The float64 picture of a packing: per batch, the kept dense rows in order.
std::vector<std::vector<size_t>> reference_kept(const std::vector<float>& pos, const PackSelect& s) {
  std::vector<std::vector<size_t>> kept(B);
  for (size_t b = 0; b < B; ++b) {
    const OccupancyGrid& g = (*s.grids)[static_cast<size_t>(s.grid_of_batch[b])];
    for (size_t m = 0; m < M; ++m) {
      // The cell by float64 arithmetic: floor((p + 1) / 2 * 4), clamped.
      size_t c = 0;
      for (int d = 2; d >= 0; --d) {
        const double u = (double(pos[(b * M + m) * 3 + d]) + 1.0) / 2.0 * g.resolution;
        // NaN lands in cell 0; anything beyond the box (infinity too) on its face.
        const int i = std::isnan(u) ? 0 : static_cast<int>(std::clamp(std::floor(u), 0.0, g.resolution - 1.0));
        c = c * static_cast<size_t>(g.resolution) + static_cast<size_t>(i);
      }
      if (g.occupied[c]) kept[b].push_back(m);
    }
  }
  return kept;
}

std::vector<std::vector<size_t>> reference_range_kept(const std::vector<float>& pos, const PackSelect& s,
                                                      const std::vector<uint8_t>& open, size_t rows) {
  return test::reference_range_kept(pos, s, open, B, rows);
}

// positions [B, rows, 3] packed, gathered and scattered back with fill -7: each kept row is
// its own position, every other row -7.
std::vector<float> run_pack_roundtrip(std::shared_ptr<PackSelect> s, const std::vector<float>& pos, size_t rows) {
  return test::run_forward(
      [&](Graph& g) {
        Tensor x = g.input("positions", Shape{B, rows, D});
        Packed p = pack_occupied(x, s);
        return test::OpUnderTest{{x}, scatter_rows(gather_rows(x, p), p, std::vector<float>(D, -7.0f))};
      },
      {pos});
}

std::vector<double> roundtrip_reference(const std::vector<float>& pos, const std::vector<std::vector<size_t>>& kept,
                                        size_t rows) {
  std::vector<double> ref(B * rows * D, -7.0);
  for (size_t b = 0; b < B; ++b)
    for (size_t m : kept[b])
      for (size_t d = 0; d < D; ++d) ref[(b * rows + m) * D + d] = pos[(b * rows + m) * D + d];
  return ref;
}

struct PackedMlp {
  Tensor positions, w, bias, out;
};

// positions [B, M, 3] -> pack -> [posenc(p), p] -> p' w + b -> ReLU -> scatter (fill -7).
PackedMlp packed_mlp(Graph& g, std::shared_ptr<PackSelect> s, bool grad) {
  PackedMlp n;
  n.positions = g.input("positions", Shape{B, M, D});
  n.w = g.input("w", Shape{B, E, H}, grad);
  n.bias = g.input("b", Shape{B, H}, grad);
  Packed p = pack_occupied(n.positions, std::move(s));
  Tensor x = gather_rows(n.positions, p);
  Tensor h = dense(concat({positional_encoding(x, F), x}), n.w, n.bias, Activation::ReLU);
  n.out = scatter_rows(h, p, std::vector<float>(H, -7.0f));
  return n;
}

// The packed MLP's dense output for these positions, weights and biases.
std::vector<float> run_packed(std::shared_ptr<PackSelect> s, const std::vector<float>& pos,
                              const std::vector<float>& w, const std::vector<float>& bias) {
  return test::run_forward(
      [&](Graph& g) {
        PackedMlp n = packed_mlp(g, s, false);
        return test::OpUnderTest{{n.positions, n.w, n.bias}, n.out};
      },
      {pos, w, bias});
}

double encoded(const std::vector<float>& pos, size_t row, size_t j) {
  // [p, sin(2^0 p), cos(2^0 p), sin(2^1 p), cos(2^1 p)] then p again.
  if (j >= D * (1 + 2 * F)) return pos[row * 3 + (j - D * (1 + 2 * F))];
  const size_t block = j / D, d = j % D;
  const double p = pos[row * 3 + d];
  if (block == 0) return p;
  const double f = std::ldexp(1.0, static_cast<int>((block - 1) / 2));
  return (block - 1) % 2 == 0 ? std::sin(f * p) : std::cos(f * p);
}

}  // namespace

BOOST_AUTO_TEST_SUITE(packing)

BOOST_AUTO_TEST_CASE(grid_geometry_and_update) {
  OccupancyGrid g(8, 2.0f, 0.05f);
  BOOST_TEST(g.occupied_fraction() == 1.0);  // never evaluated: nothing may be skipped
  BOOST_TEST(g.threshold() == -std::log(0.95) / 0.5, boost::test_tools::tolerance(1e-6));
  for (size_t c : {size_t{0}, size_t{9}, size_t{300}, g.cells() - 1}) {
    const float u[3] = {0.5f, 0.25f, 0.75f};
    float p[3];
    g.point_in(c, u, p);
    BOOST_TEST(g.cell_of(p) == c);
  }
  const float outside[3] = {-5.0f, 0.1f, 9.0f};  // clamps like the hash grid
  const float clamped[3] = {-1.99f, 0.1f, 1.99f};
  BOOST_TEST(g.cell_of(outside) == g.cell_of(clamped));
  // Beyond int's range (a turned instance's far samples in NDC): the faces, not a wild index.
  const float inf = std::numeric_limits<float>::infinity();
  const float far[3] = {inf, -1e30f, 3e9f}, far_clamped[3] = {1.99f, -1.99f, 1.99f};
  BOOST_TEST(g.cell_of(far) == g.cell_of(far_clamped));
  const float nan_x[3] = {std::nanf(""), 0.1f, -inf}, nan_clamped[3] = {-1.99f, 0.1f, -1.99f};
  BOOST_TEST(g.cell_of(nan_x) == g.cell_of(nan_clamped));
  g.update({3, 4}, {0.0f, 0.05f}, 0.5f);
  g.refresh();
  BOOST_TEST(!g.occupied[3]);  // evaluated empty
  BOOST_TEST(!g.occupied[4]);  // 0.05 is under the threshold 0.1026
  g.update({4}, {g.threshold() * 3}, 0.5f);
  g.update({4}, {0.0f}, 0.5f);  // decays to 1.5 x threshold: still occupied
  g.refresh();
  BOOST_TEST(g.occupied[4]);
  g.update({4}, {0.0f}, 0.5f);  // 0.75 x threshold
  g.refresh();
  BOOST_TEST(!g.occupied[4]);
}

// A rigid object's box bounds its grid (object-box-bounded): the cells that do not meet the
// box are empty whatever their density, and a point beyond the grid clamps into such a cell.
BOOST_AUTO_TEST_CASE(a_support_box_empties_the_cells_outside_it) {
  OccupancyGrid g(8, 2.0f, 0.05f);  // cells 0.5 wide
  g.set_support({-0.3f, -0.3f, 0.6f, 0.3f, 0.3f, 1.1f});
  // Two cells per axis meet the box: [-0.5, 0] and [0, 0.5] in x and y, [0.5, 1] and [1, 1.5] in z.
  BOOST_TEST(g.occupied_fraction() == 8.0 / 512.0);
  const float inside[3] = {0.1f, -0.2f, 0.9f}, beside[3] = {0.1f, -0.2f, -1.0f}, beyond[3] = {0.0f, 0.0f, 9.0f};
  BOOST_TEST(g.occupied[g.cell_of(inside)]);
  BOOST_TEST(!g.occupied[g.cell_of(beside)]);
  BOOST_TEST(!g.occupied[g.cell_of(beyond)]);
  // Density everywhere leaves the support as it is, and a cell in it follows its density.
  std::vector<size_t> all(g.cells());
  for (size_t c = 0; c < all.size(); ++c) all[c] = c;
  g.update(all, std::vector<float>(all.size(), 10 * g.threshold()), 0.5f);
  g.update({g.cell_of(inside)}, {0.0f}, 0.0f);
  g.refresh();
  BOOST_TEST(g.occupied_fraction() == 7.0 / 512.0);
  BOOST_TEST(!g.occupied[g.cell_of(inside)]);
  BOOST_TEST(!g.occupied[g.cell_of(beside)]);
  g.set_support({});
  BOOST_TEST(g.occupied_fraction() == 511.0 / 512.0);

  // The estimator bounds each object's grid by its objects.box row (centre, -log half-size)
  // and leaves the static NeRF's grid whole.
  OccupancyEstimator est(1, 8, 2.0f, 0.05f);
  est.bound_objects({0.0f, 0.0f, 0.85f, -std::log(0.3f), -std::log(0.3f), -std::log(0.25f)}, 0.0f);
  BOOST_TEST(est.grid(0).occupied_fraction() == 1.0);
  BOOST_TEST(est.grid(1).occupied_fraction() == 8.0 / 512.0);
  BOOST_TEST(est.grid(1).support[2] == 0.6f, boost::test_tools::tolerance(1e-6f));
  est.bound_objects({0.0f, 0.0f, 0.85f, -std::log(0.3f), -std::log(0.3f), -std::log(0.25f)}, 0.25f);
  BOOST_TEST(est.grid(1).occupied_fraction() == 4.0 * 4.0 * 3.0 / 512.0);  // x, y in [-0.55, 0.55]; z in [0.35, 1.35]
  BOOST_CHECK_THROW(est.bound_objects({0.0f}, 0.0f), Error);
}

BOOST_AUTO_TEST_CASE(pack_gather_scatter_match_reference) {
  auto sel = two_grid_select();
  const auto pos = random_floats(B * M * D, -1.2f, 1.2f, 11);
  const auto w = random_floats(B * E * H, -1.0f, 1.0f, 12);
  const auto bias = random_floats(B * H, -0.5f, 0.5f, 13);
  const auto out = run_packed(sel, pos, w, bias);
  const auto kept = reference_kept(pos, *sel);
  BOOST_TEST(sel->kept == kept[0].size() + kept[1].size());
  BOOST_TEST(sel->tested == B * M);
  // Both grids keep about half of the samples: a packing that kept all or none would not
  // test anything.
  for (const auto& k : kept) BOOST_TEST((k.size() > M / 4 && k.size() < 3 * M / 4));
  std::vector<double> ref(B * M * H, -7.0);
  for (size_t b = 0; b < B; ++b)
    for (size_t m : kept[b])
      for (size_t o = 0; o < H; ++o) {
        double h = bias[b * H + o];
        for (size_t j = 0; j < E; ++j) h += encoded(pos, b * M + m, j) * w[(b * E + j) * H + o];
        ref[(b * M + m) * H + o] = std::max(0.0, h);
      }
  test::expect_close(out, ref, 1e-5, 1e-5, "packed MLP scattered back");
}

// Samples far outside the box, infinite or NaN (an instance turned edge-on in NDC sends its
// far samples to infinity) pack by the box's faces (NaN: cell 0), as the host grid does.
BOOST_AUTO_TEST_CASE(far_and_non_finite_positions_pack_by_the_box_faces) {
  auto sel = two_grid_select();
  auto pos = random_floats(B * M * D, -1.2f, 1.2f, 17);
  const float inf = std::numeric_limits<float>::infinity();
  const float wild[] = {inf, -inf, 1e30f, -1e30f, 3e9f, -3e9f, std::nanf("")};
  for (size_t i = 0; i < pos.size(); i += 5) pos[i] = wild[(i / 5) % std::size(wild)];
  const auto kept = reference_kept(pos, *sel);
  const auto out = run_pack_roundtrip(sel, pos, M);
  BOOST_TEST(sel->kept == kept[0].size() + kept[1].size());
  size_t mismatches = 0;
  for (size_t b = 0; b < B; ++b) {
    std::vector<uint8_t> ref(M, 0);
    for (size_t m : kept[b]) ref[m] = 1;
    for (size_t m = 0; m < M; ++m) {
      const float* o = &out[(b * M + m) * D];
      const bool filled = o[0] == -7.0f && o[1] == -7.0f && o[2] == -7.0f;
      mismatches += filled == static_cast<bool>(ref[m]);
    }
  }
  BOOST_TEST(mismatches == 0u);
  for (const auto& k : kept) BOOST_TEST((k.size() > M / 4 && k.size() < 3 * M / 4));
}

BOOST_AUTO_TEST_CASE(all_empty_gives_the_fill) {
  auto sel = two_grid_select();
  auto grids = std::make_shared<std::vector<OccupancyGrid>>(*sel->grids);
  for (auto& gr : *grids) {
    std::fill(gr.density.begin(), gr.density.end(), 0.0f);
    gr.refresh();
  }
  sel->grids = grids;
  const auto out = run_packed(sel, random_floats(B * M * D, -1.0f, 1.0f, 21),
                              random_floats(B * E * H, -1.0f, 1.0f, 22), random_floats(B * H, -0.5f, 0.5f, 23));
  BOOST_TEST(sel->kept == 0u);
  test::expect_close(out, std::vector<double>(B * M * H, -7.0), 0, 0, "fill of an empty scene");
}

BOOST_AUTO_TEST_CASE(disabled_select_keeps_every_sample) {
  auto sel = two_grid_select();
  sel->enabled = false;
  // Biases in [0.5, 1] and |inputs| <= 1 keep most ReLUs open; the fill -7 must appear nowhere.
  const auto out = run_packed(sel, random_floats(B * M * D, -1.0f, 1.0f, 31),
                              random_floats(B * E * H, -1.0f, 1.0f, 32), random_floats(B * H, 0.5f, 1.0f, 33));
  BOOST_TEST(sel->kept == B * M);
  for (float v : out) BOOST_TEST(v != -7.0f);
}

// The sample range and open rays of an early-termination pass, with and without grids: 97
// rays (prime) of 12 samples, samples [3, 9) of about half of the rays. Moving floats: exact.
BOOST_AUTO_TEST_CASE(sample_range_and_open_rays_match_reference) {
  constexpr size_t rays = 97, S = 12, rows = rays * S;
  const auto pos = random_floats(B * rows * D, -1.2f, 1.2f, 51);
  std::vector<uint8_t> open(rays);
  const auto coin = random_floats(rays, 0.0f, 1.0f, 52);
  for (size_t r = 0; r < rays; ++r) open[r] = coin[r] < 0.5f;
  Buffer flags = test::runtime().alloc(rays);
  test::runtime().upload(flags.get(), open.data(), rays);
  for (bool grids : {true, false}) {
    auto sel = two_grid_select();
    if (!grids) sel->grids = nullptr;
    sel->range = {S, 3, 9, flags.get(), rays};
    const auto out = run_pack_roundtrip(sel, pos, rows);
    const auto kept = reference_range_kept(pos, *sel, open, rows);
    BOOST_TEST(sel->kept == kept[0].size() + kept[1].size());
    test::expect_close(out, roundtrip_reference(pos, kept, rows), 0, 0, grids ? "range on grids" : "range alone");
    // Each rule must drop rows the others keep, or this case would not see it applied:
    // without the open flags, or with the whole range, the reference keeps more.
    PackSelect longer = *sel;
    longer.range.first = 0;
    longer.range.end = S;
    const auto more_open = reference_range_kept(pos, *sel, {}, rows);
    const auto more_long = reference_range_kept(pos, longer, open, rows);
    for (const auto* more : {&more_open, &more_long}) BOOST_TEST((*more)[0].size() + (*more)[1].size() > sel->kept);
    BOOST_TEST(sel->kept > 0u);
  }
}

BOOST_AUTO_TEST_CASE(no_sample_range_ignores_open_rays) {
  constexpr size_t rays = 97, S = 12, rows = rays * S;
  auto sel = two_grid_select();
  sel->enabled = false;
  Buffer closed = test::runtime().alloc(rays);
  const std::vector<uint8_t> zeros(rays, 0);
  test::runtime().upload(closed.get(), zeros.data(), rays);
  sel->range.open_rays = closed.get();  // read only with samples_per_ray > 0
  sel->range.open_rays_count = rays;
  const auto pos = random_floats(B * rows * D, -1.0f, 1.0f, 61);
  const auto out = run_pack_roundtrip(sel, pos, rows);
  BOOST_TEST(sel->kept == B * rows);
  test::expect_close(out, test::to_double(pos), 0, 0, "everything kept");
}

BOOST_AUTO_TEST_CASE(bad_sample_ranges_are_refused) {
  constexpr size_t rays = 97, S = 12, rows = rays * S;
  const auto pos = random_floats(B * rows * D, -1.0f, 1.0f, 71);
  Buffer flags = test::runtime().alloc(rays);
  auto expect_refused = [&](auto change) {
    auto sel = two_grid_select();
    sel->range.samples_per_ray = S;
    sel->range.end = S;
    change(sel->range);
    BOOST_CHECK_THROW(run_pack_roundtrip(sel, pos, rows), Error);
  };
  expect_refused([](SampleRange& r) { r.end = S + 1; });
  expect_refused([](SampleRange& r) { r.first = 5, r.end = 4; });
  expect_refused([&](SampleRange& r) { r.open_rays = flags.get(), r.open_rays_count = rays - 1; });
  expect_refused([](SampleRange& r) { r.samples_per_ray = 7; });  // 1164 rows are no rays of 7
}

BOOST_AUTO_TEST_CASE(gradients_flow_through_packed_rows) {
  auto sel = two_grid_select();
  auto pos = random_floats(B * M * D, -1.2f, 1.2f, 41);
  auto w = random_floats(B * E * H, -1.0f, 1.0f, 42);
  auto bias = random_floats(B * H, -0.5f, 0.5f, 43);
  // Keep every pre-activation 0.05 from the ReLU kink the stencil would cross.
  for (size_t i = 0; i < 50; ++i) {
    bool moved = false;
    for (size_t b = 0; b < B; ++b)
      for (size_t m = 0; m < M; ++m)
        for (size_t o = 0; o < H; ++o) {
          double h = bias[b * H + o];
          for (size_t j = 0; j < E; ++j) h += encoded(pos, b * M + m, j) * w[(b * E + j) * H + o];
          if (std::fabs(h) < 0.05) {
            pos[(b * M + m) * 3] = std::fmod(pos[(b * M + m) * 3] + 0.37f, 1.2f);
            moved = true;
          }
        }
    if (!moved) break;
  }
  test::GradCheckOptions o;  // step 1e-2 moves a pre-activation by <= 1e-2 (|inputs| <= 1.2)
  const double err = test::check_gradients(
      [&](Graph& g) {
        PackedMlp n = packed_mlp(g, sel, true);
        return test::OpUnderTest{{n.positions, n.w, n.bias}, n.out};
      },
      {pos, w, bias}, o);
  BOOST_TEST(err <= 1.0);
}

BOOST_AUTO_TEST_CASE(empty_raw_fill_is_inert) {
  // A dropped sample must add no density and take no blend share: ReLU and sigmoid of the fill.
  const auto f = empty_raw_fill(kRawChannels);
  BOOST_TEST(f.size() == size_t(kRawChannels));
  BOOST_TEST(std::max(0.0f, f[kRawSigma] + 10.0f) == 0.0f);  // even with 10 sigma of noise
  BOOST_TEST(1.0f / (1.0f + std::exp(-f[kRawBlend])) == 0.0f);
}

BOOST_AUTO_TEST_SUITE_END()

// The op table's grid ops: hash_encoding (both table-gradient summations) and the packing ops
// (pack_occupied, gather_rows, scatter_rows) over 1009 rows per batch (several work-groups, a
// partial last one) and small cases.
#include <array>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <string>
#include <utility>

#include "hashgrid_reference.hpp"
#include "nova/ops/encoding/hash_encoding.hpp"
#include "nova/sampling/occupancy.hpp"
#include "nova/ops/linalg/dense.hpp"
#include "op_table.hpp"
#include "packing_reference.hpp"

namespace nova::test {

namespace {

// A configuration of the encoding with the bound and seeds of its positions and table.
struct HashCase {
  HashGridConfig config;
  float bound = 1.0f;  // positions drawn in [-bound, bound] (test_positions)
  unsigned position_seed = 31, table_seed = 32;
};

// dims[4] picks the case. 0: dims[3] 8: levels of 3 to 30 cells over a 2^8 table, the coarse
// levels dense, the fine ones hashed, so that hashed entries collect many rows each; dims[3]
// 4: 3 levels of 2 to 7 cells with 3 features over a 2^4 table, 144 entries per network: a
// table whose size is no multiple of a work-group (the atomic backward's conversion runs over
// the table).
// 1-20 (test_hashgrid's forward cases): levels from 2 to 40 cells with 3 features over a 2^10
// table, positions in +-1.5 (bound 1.5): 3-D levels up to res 9 are dense (10^3 <= 1024),
// finer ones hashed; 4-D goes hashed sooner (res 5: 6^4 > 1024). Time (the 4th coordinate)
// as space, then capped at 3 cells: res 5 becomes dense (6^3 * 4 <= 1024), so the capped
// stride is checked on dense levels too. Then a box with its own half-size per axis
// (positions in +-1.5 also test its clamp along y and z); each without and with `extend`
// (hashed levels give points outside the box cells of their own), one and two networks.
// 21-24 (test_hashgrid's table gradients): a 16-entry table (3 levels of 2 to 7 cells, 2
// features) so that most entries are hit by 23 rows and the central differences carry real
// gradients; D 3, 4, 4 with time capped at 2, and that extended (some points lie beyond the box).
HashCase hash_case(const OpShape& s) {
  HashCase h;
  HashGridConfig& c = h.config;
  const size_t which = s.dims.size() > 4 ? s.dims[4] : 0;
  if (which == 0) {
    const bool small = s.dims[3] < 8;
    c = small ? grid_config(3, 3, static_cast<int>(s.dims[3]), 2, 7) : grid_config(4, 2, static_cast<int>(s.dims[3]), 3, 30);
    return h;
  }
  if (which <= 20) {
    const size_t k = (which - 1) / 4;  // (D, time cap, box) of the five below
    static const std::array<std::pair<int, std::array<float, 3>>, 5> time_box = {
        std::pair<int, std::array<float, 3>>{0, {}}, {0, {}}, {3, {}}, {0, {1.4f, 0.8f, 1.1f}}, {3, {1.6f, 0.9f, 1.0f}}};
    c = grid_config(6, 3, 10, 2, 40);
    c.bound = h.bound = 1.5f;
    c.time_max_resolution = time_box[k].first;
    c.axis_bound = time_box[k].second;
    c.extend = (which - 1) / 2 % 2 == 1;
    h.position_seed = 3 + unsigned(s.dims[1]);
    h.table_seed = 5 + unsigned(s.dims[2]);
    return h;
  }
  c = grid_config(3, 2, 4, 2, 7);
  c.time_max_resolution = which >= 23 ? 2 : 0;
  c.extend = which == 24;
  h.position_seed = 9;
  h.table_seed = 10;
  return h;
}

HashGridConfig hash_config(const OpShape& s) { return hash_case(s).config; }

// The shapes of cases 1-24 (rows, D, networks, log2 table size, case); the forward cases are
// not differentiated by central differences (cases 21-24 are), each gradient case under both
// summations.
std::vector<OpShape> hash_case_shapes() {
  std::vector<OpShape> shapes;
  const size_t dims_of[5] = {3, 4, 4, 3, 4};
  const char* what[5] = {"", "", ", time <= 3", ", box", ", time <= 3, box"};
  for (size_t which = 1; which <= 20; ++which) {
    const size_t k = (which - 1) / 4, nets = (which - 1) % 2 + 1;
    const bool extend = (which - 1) / 2 % 2 == 1;
    OpShape sh{{37, dims_of[k], nets, 10, which}, 0,
               std::to_string(nets) + " x 37 x " + std::to_string(dims_of[k]) + ", 2^10" + what[k] + (extend ? ", extend" : "")};
    sh.no_fd = true;
    shapes.push_back(sh);
  }
  const char* grad_what[4] = {"", "", ", time <= 2", ", time <= 2, extend"};
  for (size_t which = 21; which <= 24; ++which)
    for (int variant : {0, 1}) {
      const size_t dims = which == 21 ? 3 : 4;
      shapes.push_back({{23, dims, 2, 4, which}, variant,
                        "2 x 23 x " + std::to_string(dims) + ", 2^4" + grad_what[which - 21] + (variant ? ", atomic" : ", ordered"),
                        GradCheckOptions{}});
    }
  return shapes;
}

OpEntry hash_encoding_entry() {
  OpEntry e;
  e.name = "hash_encoding";
  // dims: rows, D, networks, log2 table size[, case]; variant 0: the ordered table gradient,
  // 1: the atomic one.
  e.shapes = {{{kOddRows, 3, 1, 8}, 0, "1009 x 3, 2^8, ordered"}, {{kOddRows, 3, 1, 8}, 1, "1009 x 3, 2^8, atomic"},
              {{23, 4, 2, 4}, 0, "2 x 23 x 4, 2^4, ordered"}, {{23, 4, 2, 4}, 1, "2 x 23 x 4, 2^4, atomic"},
              {{19, 3, 1, 4}, 1, "19 x 3, 2^4, atomic"}, {{3, 3, 1, 4}, 0, "3 x 3, 2^4, ordered"}};
  for (OpShape& s : hash_case_shapes()) e.shapes.push_back(std::move(s));
  e.build = [](Graph& g, const OpShape& s) {
    const size_t rows = s.dims[0], dims = s.dims[1], nets = s.dims[2];
    Tensor p = g.input("p", nets > 1 ? Shape{nets, rows, dims} : Shape{rows, dims});
    Tensor t = g.input("table", hash_grid_table_shape(hash_config(s), nets), true);
    return OpGraph{{p, t}, {hash_encoding(p, t, hash_config(s))}, {}};
  };
  e.values = [](const OpShape& s) {
    const size_t rows = s.dims[0], dims = s.dims[1], nets = s.dims[2];
    const HashCase h = hash_case(s);
    return std::vector<std::vector<float>>{test_positions(nets * rows, dims, h.bound, h.position_seed),
                                           random_floats(hash_grid_table_shape(h.config, nets).numel(), -1, 1, h.table_seed)};
  };
  e.reference = [](const OpCase& c) {
    const size_t rows = c.shape.dims[0], dims = c.shape.dims[1], nets = c.shape.dims[2];
    const HashGridConfig hc = hash_config(c.shape);
    const std::vector<double> ref = hash_reference(c.values[0], c.values[1], rows, dims, nets, hc);
    // The kernel's grid coordinate u = (x / bound + 1) / 2 * res carries a few float32
    // roundings, up to 4 ulp of res: du <= 4 res 2^-24 per dimension. The output's slope along
    // one coordinate is at most the largest difference of two table values (2 for values in
    // [-1, 1]), so atol = D * 2 * 4 res_max 2^-24 (7.6e-5 at D = 4, res 40) plus the float32
    // sum of 16 terms; a wrong weight, vertex or hash is off by O(0.1). A cell misplaced by
    // rounding at a cell face changes nothing beyond that: D-linear interpolation is
    // continuous across faces.
    return std::vector<Expected>{{ref, {dims * 2.0 * 4.0 * hc.max_resolution * std::ldexp(1.0, -24) + 2e-6, 1e-6}}};
  };
  e.gradient = [](const OpCase& c) {
    const size_t rows = c.shape.dims[0], dims = c.shape.dims[1], nets = c.shape.dims[2];
    const HashGridConfig hc = hash_config(c.shape);
    const uint64_t T = uint64_t{1} << hc.log2_size;
    const size_t tsize = hash_grid_table_shape(hc).numel(), outs = static_cast<size_t>(hc.outputs());
    std::vector<double> ref(c.values[1].size(), 0.0);
    for (size_t b = 0; b < nets; ++b) {
      const std::vector<float> pb(c.values[0].begin() + b * rows * dims, c.values[0].begin() + (b + 1) * rows * dims);
      for_each_vertex(pb, rows, dims, hc, [&](size_t r, int l, uint64_t row, double w) {
        for (int f = 0; f < hc.features; ++f)
          ref[b * tsize + (l * T + row) * hc.features + f] += w * c.upstream[0][(b * rows + r) * outs + (l * hc.features + f)];
      });
    }
    // Up to ~rows 2^D float32 terms per entry (ordered) or an exact fixed-point sum rounded
    // once (atomic): 1e-4 of the gradient's scale, rtol 1e-6 (tests/test_hashgrid.cpp).
    return std::vector<Expected>{{}, {ref, {1e-4 * max_abs(ref), 1e-6}}};
  };
  // The encoding is linear in the table: central differences carry only float32 rounding.
  e.fd = GradCheckOptions{};
  e.flops = [](const OpShape& s) {
    const HashGridConfig hc = hash_config(s);
    return double(s.dims[0] * s.dims[2]) * hc.levels * double(1u << s.dims[1]) * (hc.features * 4 + 10);
  };
  // The summation is chosen by NOVA_HASH_BACKWARD when the executor is built and when it runs.
  e.prepare = [](const OpShape& s, const Runtime& rt) -> std::string {
    if (s.variant == 1 && !rt.info().int64_atomics) return "the device has no cl_khr_int64_base_atomics";
    setenv("NOVA_HASH_BACKWARD", s.variant == 1 ? "atomic" : "ordered", 1);
    return "";
  };
  e.restore = [] { unsetenv("NOVA_HASH_BACKWARD"); };
  return e;
}

// Three batches of positions packed against two checkerboard grids (batches 0 and 2 share
// one), gathered, offset by a per-batch bias (a differentiable op on the live rows) and
// scattered back with fill -7. Variant 1: the select disabled (every row kept). dims: rows
// per batch, the pack's row multiple (1: live rows = the largest batch's kept count).
std::shared_ptr<PackSelect> select_of(int variant) {
  auto s = std::make_shared<PackSelect>();
  s->grids = std::make_shared<std::vector<OccupancyGrid>>(std::vector<OccupancyGrid>{checker_grid(4, 0), checker_grid(4, 1)});
  s->grid_of_batch = {0, 1, 0};
  s->enabled = variant == 0;
  return s;
}

constexpr size_t kPackBatches = 3, kPackCols = 3;

OpEntry packing_entry() {
  OpEntry e;
  e.name = "packing";
  e.shapes = {{{kOddRows, 1}, 0, "3 x 1009, grids"}, {{kOddRows, 32}, 0, "3 x 1009, grids, multiple 32"},
              {{kOddRows, 1}, 1, "3 x 1009, every row"}, {{1, 1}, 0, "3 x 1, grids"}, {{5, 1}, 1, "3 x 5, every row"}};
  e.build = [](Graph& g, const OpShape& s) {
    Tensor x = g.input("positions", Shape{kPackBatches, s.dims[0], kPackCols});
    Tensor b = g.input("bias", Shape{kPackBatches, kPackCols}, true);
    Packed p = pack_occupied(x, select_of(s.variant), s.dims[1]);
    Tensor y = bias_act(gather_rows(x, p), b, Activation::Identity);
    return OpGraph{{x, b}, {scatter_rows(y, p, std::vector<float>(kPackCols, -7.0f))}, {}};
  };
  e.values = [](const OpShape& s) {
    return std::vector<std::vector<float>>{random_floats(kPackBatches * s.dims[0] * kPackCols, -1.2f, 1.2f, 11),
                                           random_floats(kPackBatches * kPackCols, -1, 1, 12)};
  };
  const auto kept_of = [](const OpCase& c) {
    const auto s = select_of(c.shape.variant);
    return reference_range_kept(c.values[0], *s, {}, kPackBatches, c.shape.dims[0]);
  };
  e.reference = [=](const OpCase& c) {
    const size_t rows = c.shape.dims[0];
    std::vector<double> ref(kPackBatches * rows * kPackCols, -7.0);
    const auto kept = kept_of(c);
    for (size_t b = 0; b < kPackBatches; ++b)
      for (size_t m : kept[b])
        for (size_t d = 0; d < kPackCols; ++d)
          ref[(b * rows + m) * kPackCols + d] = double(c.values[0][(b * rows + m) * kPackCols + d]) + c.values[1][b * kPackCols + d];
    // Moved floats plus one float32 addition of values within 2.2: one rounding.
    return std::vector<Expected>{{ref, {1e-7, 1e-6}}};
  };
  e.gradient = [=](const OpCase& c) {
    const size_t rows = c.shape.dims[0];
    std::vector<double> db(kPackBatches * kPackCols, 0.0), db_abs(db.size(), 0.0);
    const auto kept = kept_of(c);
    for (size_t b = 0; b < kPackBatches; ++b)
      for (size_t m : kept[b])
        for (size_t d = 0; d < kPackCols; ++d) {
          const double u = c.upstream[0][(b * rows + m) * kPackCols + d];
          db[b * kPackCols + d] += u;
          db_abs[b * kPackCols + d] += std::fabs(u);
        }
    // A float32 two-stage sum of up to 1009 terms: 1e-5 of the sum of their magnitudes.
    return std::vector<Expected>{{}, {db, {1e-5 * max_abs(db_abs), 0}}};
  };
  e.flops = [](const OpShape& s) { return double(kPackBatches * s.dims[0] * kPackCols) * 3; };
  return e;
}

}  // namespace

void register_grid_ops(std::vector<OpEntry>& t) {
  t.push_back(hash_encoding_entry());
  t.push_back(packing_entry());
}

}  // namespace nova::test

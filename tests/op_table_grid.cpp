// The op table's grid ops: hash_encoding (both table-gradient summations) and the packing ops
// (pack_occupied, gather_rows, scatter_rows) over 1009 rows per batch (several work-groups, a
// partial last one) and small cases.
#include <cmath>
#include <cstdlib>
#include <memory>

#include "hashgrid_reference.hpp"
#include "nova/hash_grid.hpp"
#include "nova/occupancy.hpp"
#include "nova/ops.hpp"
#include "op_table.hpp"
#include "packing_reference.hpp"

namespace nova::test {

namespace {

// dims[3] 8: levels of 3 to 30 cells over a 2^8 table, the coarse levels dense, the fine
// ones hashed, so that hashed entries collect many rows each. dims[3] 4: 3 levels of 2 to 7
// cells with 3 features over a 2^4 table, 144 entries per network: a table whose size is no
// multiple of a work-group (the atomic backward's conversion runs over the table).
HashGridConfig hash_config(const OpShape& s) {
  HashGridConfig c;
  const bool small = s.dims[3] < 8;
  c.levels = small ? 3 : 4;
  c.features = small ? 3 : 2;
  c.log2_size = static_cast<int>(s.dims[3]);
  c.min_resolution = small ? 2 : 3;
  c.max_resolution = small ? 7 : 30;
  return c;
}

OpEntry hash_encoding_entry() {
  OpEntry e;
  e.name = "hash_encoding";
  // dims: rows, D, networks, log2 table size; variant 0: the ordered table gradient, 1: the
  // atomic one.
  e.shapes = {{{kOddRows, 3, 1, 8}, 0, "1009 x 3, 2^8, ordered"}, {{kOddRows, 3, 1, 8}, 1, "1009 x 3, 2^8, atomic"},
              {{23, 4, 2, 4}, 0, "2 x 23 x 4, 2^4, ordered"}, {{23, 4, 2, 4}, 1, "2 x 23 x 4, 2^4, atomic"},
              {{19, 3, 1, 4}, 1, "19 x 3, 2^4, atomic"}, {{3, 3, 1, 4}, 0, "3 x 3, 2^4, ordered"}};
  e.build = [](Graph& g, const OpShape& s) {
    const size_t rows = s.dims[0], dims = s.dims[1], nets = s.dims[2];
    Tensor p = g.input("p", nets > 1 ? Shape{nets, rows, dims} : Shape{rows, dims});
    Tensor t = g.input("table", hash_grid_table_shape(hash_config(s), nets), true);
    return OpGraph{{p, t}, {hash_encoding(p, t, hash_config(s))}, {}};
  };
  e.values = [](const OpShape& s) {
    const size_t rows = s.dims[0], dims = s.dims[1], nets = s.dims[2];
    return std::vector<std::vector<float>>{test_positions(nets * rows, dims, 1.0f, 31),
                                           random_floats(hash_grid_table_shape(hash_config(s), nets).numel(), -1, 1, 32)};
  };
  e.reference = [](const OpCase& c) {
    const size_t rows = c.shape.dims[0], dims = c.shape.dims[1], nets = c.shape.dims[2];
    const HashGridConfig hc = hash_config(c.shape);
    const size_t tsize = hash_grid_table_shape(hc).numel();
    std::vector<double> ref;
    for (size_t b = 0; b < nets; ++b) {
      const std::vector<float> pb(c.values[0].begin() + b * rows * dims, c.values[0].begin() + (b + 1) * rows * dims);
      const std::vector<float> tb(c.values[1].begin() + b * tsize, c.values[1].begin() + (b + 1) * tsize);
      const auto r = hash_reference(pb, rows, dims, tb, hc);
      ref.insert(ref.end(), r.begin(), r.end());
    }
    // The grid coordinate carries up to 4 ulp of res per dimension, the slope of the output
    // along it is at most 2 (tests/test_hashgrid.cpp): D 2 4 res 2^-24 plus the float32 sum.
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

// The multiresolution hash encoding op (kernels/hash_encoding.cl).
#include <algorithm>
#include <cmath>

#include "nova/runtime/error.hpp"
#include "nova/graph/executor.hpp"
#include "nova/ops/encoding/hash_encoding.hpp"
#include "nova/runtime/runtime.hpp"
#include "nova/tuning/tuning.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

constexpr int kMaxDims = 4, kMaxFeatures = 8, kMaxLevels = 32;

class HashEncodingOp final : public Op {
 public:
  HashEncodingOp(size_t nets, size_t rows, size_t dims, const HashGridConfig& c, bool position_grad)
      : nets_(nets), rows_(rows), dims_(dims), c_(c), res_(hash_grid_resolutions(c)), res_t_(hash_grid_time_resolutions(c)),
        position_grad_(position_grad) {}
  std::string type() const override { return "hash_encoding"; }

  void forward(ExecContext& ctx) override {
    const size_t rows = ctx.in_rows(0, rows_);
    if (rows == 0) return;
    upload_resolutions(ctx.rt);
    ctx.launch("hash_encoding", "hashgrid_forward", build_options())
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(res_buffer_).arg(res_t_buffer_).arg(ctx.out(0))
        .arg(detail::u32(nets_, "networks")).arg(detail::u32(rows, "rows"))
        .arg(static_cast<unsigned>(c_.levels)).arg(table_size()).arg(inv_bound())
        .run(nets_ * rows * c_.levels);
  }

  void backward(ExecContext& ctx) override {
    backward_positions(ctx);
    cl_mem dy = ctx.grad_out(0), dtable = ctx.grad_in(1);
    if (!dtable) return;
    if (!dy) {  // nothing downstream reads the encoding: its table gradient is zero
      if (!ctx.accumulate_in(1))
        ctx.rt.fill_zero(dtable, nets_ * c_.levels * table_size() * c_.features * sizeof(float));
      return;
    }
    upload_resolutions(ctx.rt);
    if (parallel_backward(ctx.rt)) {
      backward_atomic(ctx, dy, dtable);
      return;
    }
    ctx.launch("hash_encoding", "hashgrid_backward", build_options())
        .arg(ctx.in(0)).arg(dy).arg(res_buffer_).arg(res_t_buffer_).arg(dtable)
        .arg(detail::u32(nets_, "networks")).arg(detail::u32(ctx.in_rows(0, rows_), "rows"))
        .arg(static_cast<unsigned>(c_.levels)).arg(table_size()).arg(inv_bound())
        .arg(static_cast<int>(ctx.accumulate_in(1)))
        .run(nets_ * c_.levels, 1);  // one (network, level) per group: every CPU thread gets some
  }

  // The table gradient needs the positions only (the table is linear in the output); the
  // positions' gradient reads the table as well.
  std::vector<TensorId> saved_for_backward() const override {
    return position_grad_ ? inputs() : std::vector<TensorId>{inputs()[0]};
  }

  // The positions' gradient, for samples moved by a learned motion (motion.hpp).
  void backward_positions(ExecContext& ctx) {
    cl_mem dy = ctx.grad_out(0), dp = ctx.grad_in(0);
    const size_t rows = ctx.in_rows(0, rows_);
    if (!dp || rows == 0) return;
    if (!dy) {
      if (!ctx.accumulate_in(0)) ctx.rt.fill_zero(dp, nets_ * rows * dims_ * sizeof(float));
      return;
    }
    upload_resolutions(ctx.rt);
    if (parallel_backward(ctx.rt)) {  // the atomic path (GPUs): one row per work-item
      ctx.launch("hash_encoding", "hashgrid_backward_positions", build_options())
          .arg(ctx.in(0)).arg(ctx.in(1)).arg(dy).arg(res_buffer_).arg(res_t_buffer_).arg(dp)
          .arg(detail::u32(nets_, "networks")).arg(detail::u32(rows, "rows"))
          .arg(static_cast<unsigned>(c_.levels)).arg(table_size()).arg(inv_bound())
          .arg(static_cast<int>(ctx.accumulate_in(0)))
          .run(nets_ * rows);
      return;
    }
    // The ordered path (CPUs): level by level into the workspace ([levels, rows, dims]), then
    // each row's levels summed in order as a column sum. One row's pass over every level's
    // table (8 MB a network) ran 4.5 times slower per row and level than the forward, which
    // reads one level's table at a time.
    ctx.launch("hash_encoding", "hashgrid_backward_positions_levels", build_options())
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(dy).arg(res_buffer_).arg(res_t_buffer_).arg(ctx.workspace())
        .arg(detail::u32(nets_, "networks")).arg(detail::u32(rows, "rows"))
        .arg(static_cast<unsigned>(c_.levels)).arg(table_size()).arg(inv_bound())
        .run(nets_ * rows * c_.levels);
    const size_t cols = nets_ * rows * dims_;
    ctx.launch("reduce", "colsum_finish")
        .arg(ctx.workspace()).arg(0u).arg(dp).arg(detail::u32(cols, "position gradients"))
        .arg(static_cast<unsigned>(c_.levels)).arg(static_cast<int>(ctx.accumulate_in(0)))
        .run(cols);
  }

  // The atomic backward's fixed-point table (a GPU), or the per-level parts of the positions'
  // gradient (a CPU's ordered backward).
  size_t workspace_bytes(Runtime& rt, Pass pass) const override {
    if (pass != Pass::Backward) return 0;
    if (parallel_backward(rt)) return table_entries() * sizeof(int64_t);
    return position_grad_ ? nets_ * rows_ * c_.levels * dims_ * sizeof(float) : 0;
  }

 private:
  size_t table_entries() const { return nets_ * c_.levels * table_size() * c_.features; }
  bool parallel_backward(const Runtime& rt) const {
    const HashBackward b = hash_backward_choice(rt.info());
    return b == HashBackward::Atomic;
  }

  // Largest |dy| (the fixed-point scale), zeroed fixed-point table, atomic sums over rows,
  // conversion to float.
  void backward_atomic(ExecContext& ctx, cl_mem dy, cl_mem dtable) {
    const size_t rows = ctx.in_rows(0, rows_);
    const size_t n = nets_ * rows * c_.levels * c_.features;
    const size_t parts = detail::reduction_parts(n);
    if (absmax_.bytes() < parts * sizeof(float)) absmax_ = ctx.rt.alloc(parts * sizeof(float));
    const std::string opts = build_options();
    ctx.launch("hash_encoding", "hashgrid_absmax_partial", opts)
        .arg(dy).arg(absmax_).arg(detail::u32(n, "encoding gradients")).arg(detail::u32(parts, "parts")).run(parts);
    ctx.launch("hash_encoding", "hashgrid_absmax_finish", opts).arg(absmax_).arg(detail::u32(parts, "parts")).run(1);
    ctx.rt.fill_zero(ctx.workspace(), table_entries() * sizeof(int64_t));
    ctx.launch("hash_encoding", "hashgrid_backward_atomic", opts)
        .arg(ctx.in(0)).arg(dy).arg(res_buffer_).arg(res_t_buffer_).arg(ctx.workspace()).arg(absmax_)
        .arg(detail::u32(nets_, "networks")).arg(detail::u32(rows, "rows"))
        .arg(static_cast<unsigned>(c_.levels)).arg(table_size()).arg(inv_bound())
        .run(nets_ * rows * c_.levels);
    ctx.launch("hash_encoding", "hashgrid_backward_fixed_to_float", opts)
        .arg(ctx.workspace()).arg(absmax_).arg(dtable).arg(detail::u32(table_entries(), "table entries"))
        .arg(detail::u32(rows, "rows")).arg(static_cast<int>(ctx.accumulate_in(1)))
        .run(table_entries());
  }

  unsigned table_size() const { return 1u << c_.log2_size; }
  // 1 / the half-size of x, y, z and time (time always spans [-1, 1]).
  cl_float4 inv_bound() const {
    return {{1.0f / c_.half_size(0), 1.0f / c_.half_size(1), 1.0f / c_.half_size(2), 1.0f}};
  }
  std::string build_options() const {
    return HashGridParams{dims_, static_cast<size_t>(c_.features), c_.extend}.to_defines();
  }
  void upload_resolutions(Runtime& rt) {
    if (!res_buffer_.get()) res_buffer_ = rt.upload_floats(res_);
    if (!res_t_buffer_.get()) res_t_buffer_ = rt.upload_floats(res_t_);
  }

  size_t nets_, rows_, dims_;
  HashGridConfig c_;
  std::vector<float> res_, res_t_;
  Buffer res_buffer_, res_t_buffer_, absmax_;
  bool position_grad_;
};

}  // namespace

void validate(const HashGridConfig& c) {
  auto fail = [](const std::string& what) { throw Error("hash grid: " + what, kExitUsage); };
  if (c.levels < 1 || c.levels > kMaxLevels)
    fail("levels must be in [1, " + std::to_string(kMaxLevels) + "], got " + std::to_string(c.levels));
  if (c.features < 1 || c.features > kMaxFeatures)
    fail("features per level must be in [1, " + std::to_string(kMaxFeatures) + "], got " +
         std::to_string(c.features));
  if (c.log2_size < 4 || c.log2_size > 24)
    fail("log2 table size must be in [4, 24], got " + std::to_string(c.log2_size));
  if (c.min_resolution < 1 || c.max_resolution < c.min_resolution || c.max_resolution > (1 << 20))
    fail("resolutions must satisfy 1 <= min <= max <= 2^20, got min " +
         std::to_string(c.min_resolution) + ", max " + std::to_string(c.max_resolution));
  if (!(c.bound > 0.0f) || !std::isfinite(c.bound))
    fail("bound must be a positive number, got " + std::to_string(c.bound));
  for (int d = 0; d < 3; ++d)
    if (!(c.axis_bound[d] >= 0.0f) || !std::isfinite(c.axis_bound[d]))
      fail(std::string("half-size along ") + "xyz"[d] + " must be positive (0: bound), got " +
           std::to_string(c.axis_bound[d]));
  if (c.time_max_resolution < 0 || c.time_max_resolution > (1 << 20))
    fail("time resolution must be in [0, 2^20] (0: as space), got " +
         std::to_string(c.time_max_resolution));
}

std::vector<float> hash_grid_resolutions(const HashGridConfig& c) {
  validate(c);
  std::vector<float> res(c.levels);
  const double growth =
      c.levels > 1 ? std::exp((std::log(c.max_resolution) - std::log(c.min_resolution)) /
                              (c.levels - 1))
                   : 1.0;
  for (int l = 0; l < c.levels; ++l)
    res[l] = static_cast<float>(
        std::max(1.0, std::floor(c.min_resolution * std::pow(growth, l) + 1e-9)));
  return res;
}

std::vector<float> hash_grid_time_resolutions(const HashGridConfig& c) {
  std::vector<float> res = hash_grid_resolutions(c);
  if (c.time_max_resolution > 0)
    for (float& r : res) r = std::min(r, static_cast<float>(c.time_max_resolution));
  return res;
}

Shape hash_grid_table_shape(const HashGridConfig& c, size_t networks) {
  Shape s{static_cast<size_t>(c.levels), size_t{1} << c.log2_size, static_cast<size_t>(c.features)};
  if (networks > 1) s.dims.insert(s.dims.begin(), networks);
  return s;
}

Tensor hash_grid_table(Graph& g, const std::string& name, const HashGridConfig& c, int networks) {
  validate(c);
  return g.parameter(name, hash_grid_table_shape(c, static_cast<size_t>(std::max(networks, 1))),
                     Init::uniform(1e-4f));
}

Tensor hash_encoding(Tensor positions, Tensor table, const HashGridConfig& c) {
  validate(c);
  const Shape& ps = positions.shape();
  const bool batched = ps.rank() == 3;
  if (!(ps.rank() == 2 || batched) || ps.cols() < 1 || ps.cols() > kMaxDims)
    throw Error("hash_encoding: positions must be [M, D] or [B, M, D] with 1 <= D <= 4, got " +
                    ps.str(),
                kExitInternal);
  const size_t nets = batched ? ps[0] : 1;
  // A batched input always has a batched table, even of one network.
  Shape ts = hash_grid_table_shape(c);
  if (batched) ts.dims.insert(ts.dims.begin(), nets);
  if (!(table.shape() == ts))
    throw Error("hash_encoding: table must be " + ts.str() + ", got " + table.shape().str(),
                kExitInternal);
  Shape out = ps;
  out.dims.back() = static_cast<size_t>(c.outputs());
  Graph& g = *positions.graph;
  Tensor y = g.activation(table.info().name + ".enc", out);
  g.add(std::make_unique<HashEncodingOp>(nets, ps.rows() / nets, ps.cols(), c, positions.info().requires_grad),
        {positions, table},
        {y});
  return y;
}

}  // namespace nova

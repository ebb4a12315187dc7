// Packed samples (occupancy.hpp): the pack test on the host, gather and scatter on the device.
#include <algorithm>

#include "nova/error.hpp"
#include "nova/executor.hpp"
#include "nova/occupancy.hpp"
#include "op_util.hpp"

namespace nova {
namespace {

// Indices are stored as floats: exact up to 2^24 rows.
constexpr size_t kMaxPackRows = size_t{1} << 24;

class PackOp final : public Op {
 public:
  PackOp(std::shared_ptr<PackSelect> s, int extent, size_t batches, size_t rows, size_t multiple)
      : select_(std::move(s)), extent_(extent), batches_(batches), rows_(rows), multiple_(multiple) {}
  std::string type() const override { return "pack_occupied"; }

  void forward(ExecContext& ctx) override {
    PackSelect& s = *select_;
    std::vector<std::vector<float>> kept(batches_);
    size_t longest = 0;
    const bool test = s.enabled && s.grids;
    const Range range = sample_range(s);
    std::vector<float> pos;
    if (test) pos = ctx.rt.download_floats(ctx.in(0), ctx.in_shape(0).numel());
    const size_t pos_batches = ctx.in_shape(0).rank() == 3 ? batches_ : 1;
    for (size_t b = 0; b < batches_; ++b) {
      const OccupancyGrid* g = nullptr;
      if (test) {
        if (b >= s.grid_of_batch.size() || s.grid_of_batch[b] < 0 ||
            static_cast<size_t>(s.grid_of_batch[b]) >= s.grids->size())
          throw Error("pack_occupied: no occupancy grid for batch " + std::to_string(b), kExitInternal);
        g = &(*s.grids)[static_cast<size_t>(s.grid_of_batch[b])];
      }
      const float* p = test ? pos.data() + (pos_batches > 1 ? b * rows_ * 3 : 0) : nullptr;
      auto& k = kept[b];
      // Rays in order, and in each the samples of the range: the kept rows stay ascending.
      for (size_t r = 0; r < range.rays; ++r) {
        if (!range.open.empty() && !range.open[r]) continue;
        for (size_t m = r * range.per_ray + range.first; m < r * range.per_ray + range.end; ++m)
          if (!g || g->occupied[g->cell_of(p + m * 3)]) k.push_back(static_cast<float>(m));
      }
      longest = std::max(longest, k.size());
    }
    s.tested = batches_ * rows_;
    s.kept = 0;
    for (const auto& k : kept) s.kept += k.size();
    const size_t live = std::min(rows_, std::max(multiple_, (longest + multiple_ - 1) / multiple_ * multiple_));
    std::vector<float> index(batches_ * live, -1.0f);
    for (size_t b = 0; b < batches_; ++b) std::copy(kept[b].begin(), kept[b].end(), index.begin() + b * live);
    ctx.rt.upload(ctx.out(0), index.data(), index.size() * sizeof(float));
    ctx.set_extent(extent_, live);
  }
  void backward(ExecContext&) override {}
  std::vector<TensorId> saved_for_backward() const override { return {}; }

 private:
  // The rows as rays of `per_ray` samples, of which [first, end) of the open rays are kept;
  // without a sample range, one "ray" holding every row.
  struct Range {
    size_t rays = 1, per_ray = 0, first = 0, end = 0;
    const std::vector<uint8_t>& open;
  };
  Range sample_range(const PackSelect& s) const {
    static const std::vector<uint8_t> all;
    if (s.samples_per_ray == 0) return {1, rows_, 0, rows_, all};
    const size_t S = s.samples_per_ray;
    if (rows_ % S != 0 || s.first_sample > s.end_sample || s.end_sample > S)
      throw Error("pack_occupied: samples [" + std::to_string(s.first_sample) + ", " + std::to_string(s.end_sample) +
                  ") of " + std::to_string(S) + " per ray do not fit " + std::to_string(rows_) + " rows", kExitInternal);
    if (!s.open_rays.empty() && s.open_rays.size() != rows_ / S)
      throw Error("pack_occupied: " + std::to_string(s.open_rays.size()) + " open-ray flags for " +
                  std::to_string(rows_ / S) + " rays", kExitInternal);
    return {rows_ / S, S, s.first_sample, s.end_sample, s.open_rays};
  }

  std::shared_ptr<PackSelect> select_;
  int extent_;
  size_t batches_, rows_, multiple_;
};

class GatherRowsOp final : public Op {
 public:
  GatherRowsOp(size_t batches, size_t dense_rows, size_t cols, bool shared)
      : batches_(batches), dense_rows_(dense_rows), cols_(cols), shared_(shared) {}
  std::string type() const override { return "gather_rows"; }

  void forward(ExecContext& ctx) override {
    const size_t live = ctx.out_rows(0, capacity(ctx));
    if (live == 0) return;
    ctx.launch("packing", "gather_rows")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.out(0)).arg(detail::u32(batches_, "batches"))
        .arg(detail::u32(live, "rows")).arg(detail::u32(cols_, "cols"))
        .arg(detail::u32(shared_ ? 0 : dense_rows_ * cols_, "batch stride")).arg(0)
        .run(batches_ * live * cols_);
  }
  // Positions and view directions are data: nothing upstream wants a gradient.
  void backward(ExecContext& ctx) override {
    if (ctx.grad_in(0)) throw Error("gather_rows: no gradient to its input", kExitInternal);
  }
  std::vector<TensorId> saved_for_backward() const override { return {}; }

 private:
  size_t capacity(ExecContext& ctx) const { return ctx.out_shape(0).dims[ctx.out_shape(0).row_dim()]; }
  size_t batches_, dense_rows_, cols_;
  bool shared_;
};

class ScatterRowsOp final : public Op {
 public:
  ScatterRowsOp(size_t batches, size_t dense_rows, size_t capacity, size_t cols, std::vector<float> fill)
      : batches_(batches), dense_rows_(dense_rows), capacity_(capacity), cols_(cols), fill_(std::move(fill)) {}
  std::string type() const override { return "scatter_rows"; }
  bool propagates_extent() const override { return false; }

  void forward(ExecContext& ctx) override {
    if (!fill_buffer_.get()) fill_buffer_ = ctx.rt.upload_floats(fill_);
    const size_t total = batches_ * dense_rows_ * cols_;
    ctx.launch("packing", "fill_rows").arg(ctx.out(0)).arg(fill_buffer_)
        .arg(detail::u32(total, "size")).arg(detail::u32(cols_, "cols")).run(total);
    const size_t live = ctx.in_rows(0, capacity_);
    if (live == 0) return;
    ctx.launch("packing", "scatter_rows")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.out(0)).arg(detail::u32(batches_, "batches"))
        .arg(detail::u32(live, "rows")).arg(detail::u32(cols_, "cols"))
        .arg(detail::u32(dense_rows_, "dense rows"))
        .run(batches_ * live * cols_);
  }

  // dy'[b, i] = d dense[b, index[b, i]]: the same gather as the forward of gather_rows.
  void backward(ExecContext& ctx) override {
    cl_mem dd = ctx.grad_out(0), dy = ctx.grad_in(0);
    const size_t live = ctx.in_rows(0, capacity_);
    if (!dy || live == 0) return;
    if (!dd) {
      if (!ctx.accumulate_in(0)) ctx.rt.fill_zero(dy, batches_ * live * cols_ * sizeof(float));
      return;
    }
    ctx.launch("packing", "gather_rows")
        .arg(dd).arg(ctx.in(1)).arg(dy).arg(detail::u32(batches_, "batches"))
        .arg(detail::u32(live, "rows")).arg(detail::u32(cols_, "cols"))
        .arg(detail::u32(dense_rows_ * cols_, "batch stride"))
        .arg(static_cast<int>(ctx.accumulate_in(0)))
        .run(batches_ * live * cols_);
  }
  // Only the index: the scatter is linear in y.
  std::vector<TensorId> saved_for_backward() const override { return {inputs()[1]}; }

 private:
  size_t batches_, dense_rows_, capacity_, cols_;
  std::vector<float> fill_;
  Buffer fill_buffer_;
};

Shape rows_shape(size_t batches, size_t rows, size_t cols) {
  return batches == 1 ? Shape{rows, cols} : Shape{batches, rows, cols};
}

}  // namespace

Packed pack_occupied(Tensor positions, std::shared_ptr<PackSelect> select, size_t multiple) {
  const Shape& s = positions.shape();
  if (!(s.rank() == 2 || s.rank() == 3) || s.cols() != 3)
    throw Error("pack_occupied: positions must be [M, 3] or [B, M, 3], got " + s.str(), kExitInternal);
  if (!select) throw Error("pack_occupied: no selection", kExitInternal);
  if (multiple == 0) throw Error("pack_occupied: multiple must be >= 1", kExitInternal);
  Graph& g = *positions.graph;
  Packed p;
  p.batches = s.rank() == 3 ? s[0] : 1;
  p.dense_rows = s[s.row_dim()];
  if (p.dense_rows >= kMaxPackRows)
    throw Error("pack_occupied: " + std::to_string(p.dense_rows) + " rows exceed 2^24", kExitUsage);
  p.extent = g.add_extent(positions.info().name + ".packed", p.dense_rows);
  p.index = g.activation(positions.info().name + ".pack_index", rows_shape(p.batches, p.dense_rows, 1));
  g.bind_extent(p.index, p.extent);
  g.add(std::make_unique<PackOp>(std::move(select), p.extent, p.batches, p.dense_rows, multiple),
        {positions}, {p.index});
  return p;
}

Tensor gather_rows(Tensor x, const Packed& p) {
  const Shape& s = x.shape();
  const bool shared = s.rank() == 2;
  if (!(shared || (s.rank() == 3 && s[0] == p.batches)) || s[s.row_dim()] != p.dense_rows)
    throw Error("gather_rows: " + s.str() + " does not fit a packing of " + std::to_string(p.batches) +
                " x " + std::to_string(p.dense_rows) + " rows", kExitInternal);
  Graph& g = *x.graph;
  Tensor y = g.activation(x.info().name + ".packed", rows_shape(p.batches, p.dense_rows, s.cols()));
  g.bind_extent(y, p.extent);
  g.add(std::make_unique<GatherRowsOp>(p.batches, p.dense_rows, s.cols(), shared), {x, p.index}, {y});
  return y;
}

Tensor scatter_rows(Tensor y, const Packed& p, const std::vector<float>& fill) {
  const Shape& s = y.shape();
  if (!(s == rows_shape(p.batches, p.dense_rows, s.cols())) || y.info().extent != p.extent)
    throw Error("scatter_rows: " + s.str() + " is not a tensor of this packing", kExitInternal);
  if (fill.size() != s.cols())
    throw Error("scatter_rows: " + std::to_string(fill.size()) + " fill values for " +
                std::to_string(s.cols()) + " columns", kExitInternal);
  Graph& g = *y.graph;
  Tensor dense = g.activation(y.info().name + ".dense", rows_shape(p.batches, p.dense_rows, s.cols()));
  g.add(std::make_unique<ScatterRowsOp>(p.batches, p.dense_rows, p.dense_rows, s.cols(), fill),
        {y, p.index}, {dense});
  return dense;
}

}  // namespace nova

// Packed samples (occupancy.hpp): the pack test, its compaction, gather and scatter, all on the
// device.
#include <algorithm>

#include "nova/runtime/error.hpp"
#include "nova/graph/executor.hpp"
#include "nova/sampling/occupancy.hpp"
#include "nova/tuning/tuning.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

// Indices are stored as floats: exact up to 2^24 rows.
constexpr size_t kMaxPackRows = size_t{1} << 24;


class PackOp final : public Op {
 public:
  PackOp(std::shared_ptr<PackSelect> s, int extent, size_t batches, size_t rows, size_t multiple)
      : select_(std::move(s)), extent_(extent), batches_(batches), rows_(rows), multiple_(multiple),
        blocks_((rows + pack_.block - 1) / pack_.block) {}
  std::string type() const override { return "pack_occupied"; }

  void forward(ExecContext& ctx) override {
    PackSelect& s = *select_;
    const bool test = s.enabled && s.grids;
    const Range range = sample_range(s);
    const unsigned B = detail::u32(batches_, "pack batches"), M = detail::u32(rows_, "pack rows");
    s.tested = batches_ * rows_;
    if (!test && range.keeps_all) {
      ctx.launch("packing", "pack_identity").arg(ctx.out(0)).arg(B).arg(M).run(batches_ * rows_);
      s.kept = batches_ * rows_;
      ctx.set_extent(extent_, rows_);
      return;
    }
    Runtime& rt = ctx.rt;
    ensure_scratch(rt);
    if (test) upload_grids(rt, s);
    const bool use_open = range.open != nullptr;
    const std::string opts = pack_.to_defines();
    const unsigned nb = detail::u32(blocks_, "pack blocks");
    ctx.launch("packing", "pack_flags", opts)
        .arg(ctx.in(0)).arg(occupied_).arg(cell_offset_).arg(res_).arg(bound_).arg(scale_).arg(use_open ? range.open : open_.get())
        .arg(flags_).arg(B).arg(M).arg(static_cast<unsigned>(ctx.in_shape(0).rank() == 3))
        .arg(detail::u32(range.per_ray, "samples per ray")).arg(detail::u32(range.first, "first sample"))
        .arg(detail::u32(range.end, "end sample")).arg(static_cast<int>(test)).arg(static_cast<int>(use_open))
        .run(batches_ * rows_);
    ctx.launch("packing", "pack_block_counts", opts).arg(flags_).arg(offsets_).arg(B).arg(M).arg(nb)
        .run(batches_ * blocks_);
    ctx.launch("packing", "pack_scan", opts).arg(offsets_).arg(totals_).arg(B).arg(nb).run(batches_);
    // The one read of a run: B counts, which size every later launch of the pass.
    std::vector<uint32_t> total(batches_);
    rt.download(totals_.get(), total.data(), total.size() * sizeof(uint32_t));
    size_t longest = 0;
    s.kept = 0;
    for (uint32_t n : total) {
      longest = std::max<size_t>(longest, n);
      s.kept += n;
    }
    const size_t live = std::min(rows_, std::max(multiple_, (longest + multiple_ - 1) / multiple_ * multiple_));
    const unsigned L = detail::u32(live, "packed rows");
    ctx.launch("packing", "pack_write", opts).arg(flags_).arg(offsets_).arg(ctx.out(0)).arg(B).arg(M).arg(nb).arg(L)
        .run(batches_ * blocks_);
    ctx.launch("packing", "pack_pad", opts).arg(ctx.out(0)).arg(totals_).arg(B).arg(L).run(batches_ * live);
    ctx.set_extent(extent_, live);
  }
  void backward(ExecContext&) override {}
  std::vector<TensorId> saved_for_backward() const override { return {}; }

 private:
  // The rows as rays of `per_ray` samples, of which [first, end) of the open rays are kept;
  // without a sample range, one "ray" holding every row.
  struct Range {
    size_t per_ray = 0, first = 0, end = 0;
    cl_mem open = nullptr;
    bool keeps_all = false;
  };
  Range sample_range(const PackSelect& s) const {
    const SampleRange& r = s.range;
    if (r.samples_per_ray == 0) return {rows_, 0, rows_, nullptr, true};
    const size_t S = r.samples_per_ray;
    if (rows_ % S != 0 || r.first > r.end || r.end > S)
      throw Error("pack_occupied: samples [" + std::to_string(r.first) + ", " + std::to_string(r.end) +
                  ") of " + std::to_string(S) + " per ray do not fit " + std::to_string(rows_) + " rows", kExitInternal);
    if (r.open_rays && r.open_rays_count != rows_ / S)
      throw Error("pack_occupied: " + std::to_string(r.open_rays_count) + " open-ray flags for " +
                  std::to_string(rows_ / S) + " rays", kExitInternal);
    return {S, r.first, r.end, r.open_rays, r.first == 0 && r.end == S && !r.open_rays};
  }

  // Per-run scratch, owned by the op (B x M flag bytes and a few counts per block).
  void ensure_scratch(Runtime& rt) {
    if (flags_) return;
    flags_ = rt.alloc(std::max<size_t>(batches_ * rows_, 4));
    offsets_ = rt.alloc(batches_ * blocks_ * sizeof(uint32_t));
    totals_ = rt.alloc(batches_ * sizeof(uint32_t));
    open_ = rt.alloc(4);  // stands in for a null open-ray buffer (unread)
    // Unused until a grid is uploaded, but every kernel argument needs a buffer.
    for (Buffer* b : {&occupied_, &cell_offset_, &res_, &bound_, &scale_}) *b = rt.alloc(std::max<size_t>(batches_, 1) * 4);
  }

  // Copies the grids' cells and each batch's grid geometry to the device when a grid has a
  // new generation or the batches map to other grids; otherwise nothing crosses the bus.
  void upload_grids(Runtime& rt, const PackSelect& s) {
    std::vector<uint64_t> key(s.grid_of_batch.begin(), s.grid_of_batch.end());
    for (const OccupancyGrid& g : *s.grids) key.push_back(g.generation);
    key.push_back(s.grids->size());
    if (key == uploaded_) return;
    std::vector<uint32_t> start;
    std::vector<uint8_t> cells;
    for (const OccupancyGrid& g : *s.grids) {
      start.push_back(detail::u32(cells.size(), "occupancy cells"));
      cells.insert(cells.end(), g.occupied.begin(), g.occupied.end());
    }
    std::vector<uint32_t> offset, res;
    std::vector<float> bound, scale;
    for (size_t b = 0; b < batches_; ++b) {
      if (b >= s.grid_of_batch.size() || s.grid_of_batch[b] < 0 ||
          static_cast<size_t>(s.grid_of_batch[b]) >= s.grids->size())
        throw Error("pack_occupied: no occupancy grid for batch " + std::to_string(b), kExitInternal);
      const size_t k = static_cast<size_t>(s.grid_of_batch[b]);
      const OccupancyGrid& g = (*s.grids)[k];
      offset.push_back(start[k]);
      res.push_back(static_cast<uint32_t>(g.resolution));
      bound.push_back(g.bound);
      scale.push_back(static_cast<float>(g.resolution) / (2.0f * g.bound));
    }
    if (occupied_.bytes() < cells.size()) occupied_ = rt.alloc(cells.size());
    rt.upload(occupied_.get(), cells.data(), cells.size());
    rt.upload(cell_offset_.get(), offset.data(), offset.size() * 4);
    rt.upload(res_.get(), res.data(), res.size() * 4);
    rt.upload(bound_.get(), bound.data(), bound.size() * 4);
    rt.upload(scale_.get(), scale.data(), scale.size() * 4);
    uploaded_ = std::move(key);
  }

  // Rows per compaction block (PACK_BLOCK): declared first, it sizes blocks_.
  const PackParams pack_ = pack_params();
  std::shared_ptr<PackSelect> select_;
  int extent_;
  size_t batches_, rows_, multiple_, blocks_;
  Buffer flags_, offsets_, totals_, open_, occupied_, cell_offset_, res_, bound_, scale_;
  std::vector<uint64_t> uploaded_;
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

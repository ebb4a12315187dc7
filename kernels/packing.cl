// Packed samples: the rows an occupancy test kept, gathered densely so that the MLPs run on
// them alone, and the MLP outputs scattered back to the dense [B, M, C] layout the renderer
// reads. `index` holds, per batch b and packed row i, the dense row (an integer stored as a
// float, exact below 2^24) or -1 for padding; it is laid out [B, live].

// y[b, i, c] (+)= x[b, index[b, i], c] (0 for padding); x_batch_stride 0 shares one x
// between all batches.
__kernel void gather_rows(__global const float* x, __global const float* index,
                          __global float* y, uint batches, uint live, uint cols,
                          uint x_batch_stride, int accumulate) {
  const uint t = get_global_id(0);
  if (t >= batches * live * cols) return;
  const uint c = t % cols, row = t / cols, b = row / live;
  const float f = index[row];
  const float v = f >= 0.0f ? x[(size_t)b * x_batch_stride + (size_t)f * cols + c] : 0.0f;
  y[t] = accumulate ? y[t] + v : v;
}

// dense[b, m, c] = fill[c]: what a row nobody computed holds (no density, no blend).
__kernel void fill_rows(__global float* dense, __constant float* fill, uint total, uint cols) {
  const uint t = get_global_id(0);
  if (t >= total) return;
  dense[t] = fill[t % cols];
}

// dense[b, index[b, i], c] = y[b, i, c]; the kept rows of a batch are distinct, so no two
// work-items write one element.
__kernel void scatter_rows(__global const float* y, __global const float* index,
                           __global float* dense, uint batches, uint live, uint cols,
                           uint dense_rows) {
  const uint t = get_global_id(0);
  if (t >= batches * live * cols) return;
  const uint c = t % cols, row = t / cols, b = row / live;
  const float f = index[row];
  if (f >= 0.0f) dense[((size_t)b * dense_rows + (size_t)f) * cols + c] = y[t];
}

// ---- The packing itself: which rows survive, and their compaction in order -----------------
// Rows per block of the compaction: one work-item counts, then writes, one block.
#ifndef PACK_BLOCK
#define PACK_BLOCK 128
#endif

// flags[b, m] = 1 when row m of batch b survives: inside its ray's sample range (rows are
// ray-major, `per_ray` samples per ray, [first, end) kept, only rays with open[r] != 0 when
// use_open) and, when use_grid, in an occupied cell of batch b's grid. The grids are one byte
// per cell, all grids end to end; batch b's grid starts at cell_offset[b], has res[b] cells
// per axis and maps p to (p + bound[b]) * scale[b] (the host's OccupancyGrid::cell_of, the
// same float operations, so the same cell).
__kernel void pack_flags(__global const float* positions, __global const uchar* occupied,
                         __global const uint* cell_offset, __global const uint* res,
                         __global const float* bound, __global const float* scale,
                         __global const uchar* open, __global uchar* flags, uint batches,
                         uint rows, uint positions_batched, uint per_ray, uint first, uint end,
                         int use_grid, int use_open) {
  const uint t = get_global_id(0);
  if (t >= batches * rows) return;
  const uint b = t / rows, m = t % rows, s = m % per_ray;
  uchar keep = s >= first && s < end && (!use_open || open[m / per_ray] != 0);
  if (keep && use_grid) {
    __global const float* p = positions + ((size_t)(positions_batched ? b : 0) * rows + m) * 3;
    const int n = (int)res[b];
    uint c = 0;
    for (int d = 2; d >= 0; --d) {
      const float u = (p[d] + bound[b]) * scale[b];
      // NaN compares false and lands in cell 0, as on the host. Clamped as a float first: a
      // point turned out to infinity (an instance seen edge-on in NDC) must not overflow int.
      const int i = u >= 0.0f ? (int)fmin(u, (float)(n - 1)) : 0;
      c = c * (uint)n + (uint)i;
    }
    keep = occupied[cell_offset[b] + c];
  }
  flags[t] = keep;
}

// counts[b, j] = survivors among rows [j PACK_BLOCK, (j + 1) PACK_BLOCK) of batch b.
__kernel void pack_block_counts(__global const uchar* flags, __global uint* counts, uint batches,
                                uint rows, uint blocks) {
  const uint t = get_global_id(0);
  if (t >= batches * blocks) return;
  const uint b = t / blocks, j = t % blocks;
  const uint lo = j * PACK_BLOCK, hi = min(lo + PACK_BLOCK, rows);
  uint n = 0;
  for (uint m = lo; m < hi; ++m) n += flags[(size_t)b * rows + m];
  counts[t] = n;
}

// Exclusive prefix sum of each batch's block counts, in place; total[b] = survivors of batch
// b. One work-item per batch: a few hundred additions, in a fixed order.
__kernel void pack_scan(__global uint* counts, __global uint* total, uint batches, uint blocks) {
  const uint b = get_global_id(0);
  if (b >= batches) return;
  uint sum = 0;
  for (uint j = 0; j < blocks; ++j) {
    const uint n = counts[b * blocks + j];
    counts[b * blocks + j] = sum;
    sum += n;
  }
  total[b] = sum;
}

// index[b, i] for the survivors of block j, ascending from the block's offset: the packed
// rows keep the dense order.
__kernel void pack_write(__global const uchar* flags, __global const uint* offsets,
                         __global float* index, uint batches, uint rows, uint blocks, uint live) {
  const uint t = get_global_id(0);
  if (t >= batches * blocks) return;
  const uint b = t / blocks, j = t % blocks;
  const uint lo = j * PACK_BLOCK, hi = min(lo + PACK_BLOCK, rows);
  uint at = offsets[t];
  for (uint m = lo; m < hi; ++m)
    if (flags[(size_t)b * rows + m]) index[(size_t)b * live + at++] = (float)m;
}

// index[b, i] = -1 for the padding rows i >= total[b] of a [B, live] index.
__kernel void pack_pad(__global float* index, __global const uint* total, uint batches, uint live) {
  const uint t = get_global_id(0);
  if (t >= batches * live) return;
  if (t % live >= total[t / live]) index[t] = -1.0f;
}

// index[b, m] = m: every row kept (no grid and no sample range).
__kernel void pack_identity(__global float* index, uint batches, uint rows) {
  const uint t = get_global_id(0);
  if (t >= batches * rows) return;
  index[t] = (float)(t % rows);
}

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

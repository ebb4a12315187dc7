// Data movement: column blocks for concatenation and its backward (split).

// dst[r, offset + c] = src[r, c] for a src of src_cols columns inside dst of dst_cols; a 2D
// range (c, r) so that no work-item divides, and a CPU device vectorises along a row.
__kernel void copy_cols(__global const float* src, __global float* dst, uint rows, uint src_cols,
                        uint dst_cols, uint offset) {
  const uint c = get_global_id(0), r = get_global_id(1);
  if (c >= src_cols || r >= rows) return;
  dst[(size_t)r * dst_cols + offset + c] = src[(size_t)r * src_cols + c];
}

// Two parts at once (a concatenation's pair, one launch instead of two): dst[r, offset + c] =
// src0[r, c] for c < cols0, src1[r, c - cols0] for the next cols1 columns.
__kernel void copy_cols2(__global const float* src0, __global const float* src1, __global float* dst,
                         uint rows, uint cols0, uint cols1, uint dst_cols, uint offset) {
  const uint c = get_global_id(0), r = get_global_id(1);
  if (c >= cols0 + cols1 || r >= rows) return;
  dst[(size_t)r * dst_cols + offset + c] =
      c < cols0 ? src0[(size_t)r * cols0 + c] : src1[(size_t)r * cols1 + (c - cols0)];
}

// Its backward: dsrc0 and dsrc1 (+)= their columns of ddst; bit 0 / 1 of `wanted`: dsrc0 /
// dsrc1 is written, bit 2 / 3 of it: added to. An unwanted part's buffer may be the other's.
__kernel void copy_cols2_back(__global const float* ddst, __global float* dsrc0, __global float* dsrc1,
                              uint rows, uint cols0, uint cols1, uint dst_cols, uint offset, uint wanted) {
  const uint c = get_global_id(0), r = get_global_id(1);
  if (c >= cols0 + cols1 || r >= rows) return;
  const float g = ddst[(size_t)r * dst_cols + offset + c];
  if (c < cols0) {
    if (!(wanted & 1u)) return;
    const size_t i = (size_t)r * cols0 + c;
    dsrc0[i] = (wanted & 4u) ? dsrc0[i] + g : g;
  } else {
    if (!(wanted & 2u)) return;
    const size_t i = (size_t)r * cols1 + (c - cols0);
    dsrc1[i] = (wanted & 8u) ? dsrc1[i] + g : g;
  }
}

// dsrc[r, c] (+)= ddst[r, offset + c], over the same 2D range as copy_cols.
__kernel void copy_cols_back(__global const float* ddst, __global float* dsrc, uint rows,
                             uint src_cols, uint dst_cols, uint offset, int accumulate) {
  const uint c = get_global_id(0), r = get_global_id(1);
  if (c >= src_cols || r >= rows) return;
  const size_t i = (size_t)r * src_cols + c;
  const float g = ddst[(size_t)r * dst_cols + offset + c];
  dsrc[i] = accumulate ? dsrc[i] + g : g;
}

// Backward of a gradient gate: dx[m, c] (+)= dy[m, c] gate[offset + m / group] (its forward
// is a copy).
__kernel void gate_rows_back(__global const float* dy, __global const float* gate,
                             __global float* dx, uint rows, uint cols, uint group, uint offset,
                             uint gated, int accumulate) {
  const uint i = get_global_id(0);
  if (i >= rows * cols) return;
  const float g = i % cols < gated ? dy[i] * gate[offset + i / cols / group] : dy[i];
  dx[i] = accumulate ? dx[i] + g : g;
}

// out[b, m, c] = x[b, c]: one row per batch repeated `rows` times (a per-group constant, such
// as each object's time, spread over its samples on the device).
__kernel void repeat_rows(__global const float* x, __global float* out, uint batches, uint rows,
                          uint cols) {
  const uint i = get_global_id(0);
  if (i >= batches * rows * cols) return;
  out[i] = x[(i / (rows * cols)) * cols + i % cols];
}

// y[m, c] (+)= x[m, c] w[c]: a per-column weight (a coarse-to-fine window over an encoding's
// levels). Its backward is the same product of the upstream gradient.
__kernel void scale_cols(__global const float* x, __global const float* w, __global float* y,
                         uint rows, uint cols, int accumulate) {
  const uint i = get_global_id(0);
  if (i >= rows * cols) return;
  const float v = x[i] * w[i % cols];
  y[i] = accumulate ? y[i] + v : v;
}

// out = y + bound tanh(raw): a position moved by a bounded learned offset (a deformation that
// cannot leave the neighbourhood of the rigid motion's point).
__kernel void bounded_offset(__global const float* y, __global const float* raw, __global float* out,
                             uint n, float bound) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  out[i] = y[i] + bound * tanh(raw[i]);
}

// Its backward: dy (+)= dout; draw (+)= dout bound (1 - tanh^2 raw).
__kernel void bounded_offset_back(__global const float* raw, __global const float* dout, __global float* dy,
                                  __global float* draw, uint n, float bound, int has_dy, int acc_dy,
                                  int has_draw, int acc_draw) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  const float g = dout[i];
  if (has_dy) dy[i] = acc_dy ? dy[i] + g : g;
  if (has_draw) {
    const float t = tanh(raw[i]);
    const float v = g * bound * (1.0f - t * t);
    draw[i] = acc_draw ? draw[i] + v : v;
  }
}

// out = (x - c) exp(l) per axis, with box row b = (c, l) of batch b (rows [B, M, 3]): a
// rigid object's canonical position in the coordinates of its own box.
__kernel void box_coordinates(__global const float* x, __global const float* box, __global float* out,
                              uint rows, uint n) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  __global const float* b = box + (size_t)(i / (rows * 3)) * 6;
  const uint j = i % 3;
  out[i] = (x[i] - b[j]) * exp(b[3 + j]);
}

// Its backward in x: dx (+)= dout exp(l).
__kernel void box_coordinates_back(__global const float* dout, __global const float* box, __global float* dx,
                                   uint rows, uint n, int accumulate) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  const float v = dout[i] * exp(box[(size_t)(i / (rows * 3)) * 6 + 3 + i % 3]);
  dx[i] = accumulate ? dx[i] + v : v;
}

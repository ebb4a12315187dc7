// Multiresolution hash encoding (Mueller et al. 2022, Instant-NGP): per level l a grid of
// resolution res[l] over the box [-bx, bx] x [-by, by] x [-bz, bz]; a point's feature is the
// D-linear interpolation of the 2^D vertices of its cell. A level whose (res + 1)^D vertices
// fit into the table is indexed densely, a finer one through the spatial hash
// XOR_d (v_d * prime_d) mod T (T a power of two).
//
// Layout: positions [B, M, D]; table [B, L, T, F]; out [B, M, L * F]; res [L] (floats that
// hold integers); inv_bound = (1/bx, 1/by, 1/bz, 1). With D = 4 the last coordinate is time:
// it spans [-1, 1] at res_t[l] cells, which may be coarser than space so that the fine levels
// are shared by neighbouring frames (a monocular video sees each time from one camera only).
// D (HG_DIMS, <= 4: xyz or xyzt) and F (HG_FEATURES, <= 8) are build options, so the corner
// and feature loops unroll (3x faster on PoCL than runtime bounds).
//
// Two backwards, both bit-reproducible (exact resume): the ordered one writes the table
// gradient without atomics, one work-item per (network, level) walking the rows in order
// (levels and networks give its parallelism: enough for a CPU); the atomic one (at the end of
// this file) is parallel over rows and sums in fixed point (for GPUs).

#ifndef HG_DIMS
#define HG_DIMS 3
#endif
#ifndef HG_FEATURES
#define HG_FEATURES 2
#endif
#define HG_CORNERS (1u << HG_DIMS)

#ifndef HG_EXTEND
#define HG_EXTEND 0
#endif

// Cell and fractional position of coordinate x at resolution res: clamped to the box
// [-bound, bound], or with `extend` (hashed levels under HG_EXTEND) in cells of its own
// beyond it, which the hash folds into the table like any other (a point inside the box gets
// the same cell and fraction either way). Extended cells are limited to +-2^20 from the box.
inline void hg_cell(float x, float inv_bound, float res, int extend, uint* cell, float* frac) {
  float u = 0.5f * (x * inv_bound + 1.0f);
  u = extend ? clamp(u, -1048576.0f, 1048576.0f) : clamp(u, 0.0f, 1.0f);
  u *= res;
  float f = floor(u);
  if (!extend && f > res - 1.0f) f = res - 1.0f;  // u == res: last cell, fraction 1
  *cell = (uint)(int)f;  // a cell before the box wraps, which the hash does not mind
  *frac = u - f;
}

// Cells along dimension d: time (the 4th) has its own count.
inline uint hg_res_of(uint d, uint res, uint res_t) { return (HG_DIMS == 4 && d == 3) ? res_t : res; }

inline int hg_dense(uint res, uint res_t, uint table_size) {
  ulong n = 1;
  for (uint d = 0; d < HG_DIMS; ++d) {
    n *= (ulong)hg_res_of(d, res, res_t) + 1;
    if (n > table_size) return 0;
  }
  return 1;
}

// Cell and fraction of every coordinate of point p at level resolutions (res, res_t).
// Time is never extended (it lies in [-1, 1]).
inline void hg_cells(__global const float* p, float4 inv_bound, float res, float res_t, int dense,
                     uint* cell, float* frac) {
  const float inv[4] = {inv_bound.x, inv_bound.y, inv_bound.z, inv_bound.w};
  for (uint d = 0; d < HG_DIMS; ++d) {
    const int is_t = (HG_DIMS == 4) ? (d == 3) : 0;
    const int extend = HG_EXTEND ? ((dense | is_t) == 0) : 0;  // neither a dense level nor time
    hg_cell(p[d], inv[d], is_t ? res_t : res, extend, &cell[d], &frac[d]);
  }
}

// The table rows and weights of the 2^D vertices around point r of network b at level l.
// hg_level forms, per dimension, the two candidate terms (hash: v * prime, dense: v * stride)
// and the two weights (1 - frac, frac) of point p at level l, and says whether the level is
// dense; a corner XORs (or adds) one term per dimension and multiplies one weight per
// dimension. Corner c takes bit d of c along dimension d. The corner loops unroll (HG_DIMS is
// a build option), so the bit tests fold away.
inline int hg_level(__global const float* p, __constant float* res, __constant float* res_t, uint l,
                    uint table_size, float4 inv_bound, uint term[HG_DIMS][2], float w1[HG_DIMS][2],
                    float* frac) {
  const uint primes[4] = {1u, 2654435761u, 805459861u, 3674653429u};
  const uint resolution = (uint)res[l], resolution_t = (uint)res_t[l];
  const int dense = hg_dense(resolution, resolution_t, table_size);
  uint cell[HG_DIMS];
  hg_cells(p, inv_bound, res[l], res_t[l], dense, cell, frac);
  uint stride = 1;
  for (uint d = 0; d < HG_DIMS; ++d) {
    const uint scale = dense ? stride : primes[d];
    term[d][0] = cell[d] * scale;
    term[d][1] = (cell[d] + 1u) * scale;
    w1[d][0] = 1.0f - frac[d];
    w1[d][1] = frac[d];
    stride *= hg_res_of(d, resolution, resolution_t) + 1;
  }
  return dense;
}

// The table row of corner c from hg_level's terms.
inline uint hg_vertex(uint term[HG_DIMS][2], int dense, uint table_size, uint c) {
  uint index = term[0][c & 1u];
  for (uint d = 1; d < HG_DIMS; ++d) {
    const uint bit = (c >> d) & 1u;
    index = dense ? index + term[d][bit] : index ^ term[d][bit];
  }
  return index & (dense ? 0xffffffffu : table_size - 1);
}

inline void hg_corners(__global const float* positions, uint b, uint rows, uint r, uint l,
                       __constant float* res, __constant float* res_t, uint table_size,
                       float4 inv_bound, uint* vertex, float* weight) {
  uint term[HG_DIMS][2];
  float w1[HG_DIMS][2], frac[HG_DIMS];
  const int dense = hg_level(positions + ((size_t)b * rows + r) * HG_DIMS, res, res_t, l, table_size,
                             inv_bound, term, w1, frac);
  for (uint c = 0; c < HG_CORNERS; ++c) {
    float w = w1[0][c & 1u];
    for (uint d = 1; d < HG_DIMS; ++d) w *= w1[d][(c >> d) & 1u];
    vertex[c] = hg_vertex(term, dense, table_size, c);
    weight[c] = w;
  }
}

// One work-item per (network, level, row), rows fastest.
__kernel void hashgrid_forward(__global const float* positions, __global const float* table,
                               __constant float* res, __constant float* res_t,
                               __global float* out, uint nets, uint rows, uint levels,
                               uint table_size, float4 inv_bound) {
  const uint i = get_global_id(0);
  if (i >= nets * levels * rows) return;
  const uint r = i % rows, l = (i / rows) % levels, b = i / (rows * levels);
  uint v[HG_CORNERS];
  float w[HG_CORNERS];
  hg_corners(positions, b, rows, r, l, res, res_t, table_size, inv_bound, v, w);
  float acc[HG_FEATURES];
  for (uint f = 0; f < HG_FEATURES; ++f) acc[f] = 0.0f;
  __global const float* t = table + ((size_t)b * levels + l) * table_size * HG_FEATURES;
  for (uint c = 0; c < HG_CORNERS; ++c)
    for (uint f = 0; f < HG_FEATURES; ++f) acc[f] += w[c] * t[(size_t)v[c] * HG_FEATURES + f];
  __global float* o = out + ((size_t)b * rows + r) * levels * HG_FEATURES + l * HG_FEATURES;
  for (uint f = 0; f < HG_FEATURES; ++f) o[f] = acc[f];
}

// d table: one work-item per (network, level).
__kernel void hashgrid_backward(__global const float* restrict positions,
                                __global const float* restrict dout,
                                __constant float* res, __constant float* res_t,
                                __global float* restrict dtable, uint nets, uint rows, uint levels,
                                uint table_size, float4 inv_bound, int accumulate) {
  const uint i = get_global_id(0);
  if (i >= nets * levels) return;
  const uint l = i % levels, b = i / levels;
  __global float* g = dtable + ((size_t)b * levels + l) * table_size * HG_FEATURES;
  if (!accumulate)
    for (size_t k = 0; k < (size_t)table_size * HG_FEATURES; ++k) g[k] = 0.0f;

  for (uint r = 0; r < rows; ++r) {
    uint v[HG_CORNERS];
    float w[HG_CORNERS];
    hg_corners(positions, b, rows, r, l, res, res_t, table_size, inv_bound, v, w);
    __global const float* dy = dout + ((size_t)b * rows + r) * levels * HG_FEATURES + l * HG_FEATURES;
    for (uint c = 0; c < HG_CORNERS; ++c)
      for (uint f = 0; f < HG_FEATURES; ++f) g[(size_t)v[c] * HG_FEATURES + f] += w[c] * dy[f];
  }
}

// d positions (a moved object's samples: rigid_motion). The derivative of a vertex weight
// along dimension d is the product of the other dimensions' weights, signed by the vertex's
// side, times the cells per unit of x; a coordinate clamped to the box (not extended) has none.
// hg_position_grad_level adds level l's part of point p's gradient to grad (t: the network's
// table at level l, dy: the point's dout at level l).
inline void hg_position_grad_level(__global const float* p, __global const float* t,
                                   __global const float* dy, __constant float* res,
                                   __constant float* res_t, uint l, uint table_size,
                                   float4 inv_bound, float* grad) {
  const float inv[4] = {inv_bound.x, inv_bound.y, inv_bound.z, inv_bound.w};
  uint term[HG_DIMS][2];
  float w1[HG_DIMS][2], frac[HG_DIMS], du[HG_DIMS];
  const int dense = hg_level(p, res, res_t, l, table_size, inv_bound, term, w1, frac);
  for (uint d = 0; d < HG_DIMS; ++d) {
    const int is_t = (HG_DIMS == 4) ? (d == 3) : 0;
    const int extend = HG_EXTEND ? ((dense | is_t) == 0) : 0;
    const float u = 0.5f * (p[d] * inv[d] + 1.0f);
    const int inside = extend ? (u > -1048576.0f && u < 1048576.0f) : (u > 0.0f && u < 1.0f);
    du[d] = inside ? 0.5f * inv[d] * (is_t ? res_t[l] : res[l]) : 0.0f;
  }
  for (uint c = 0; c < HG_CORNERS; ++c) {
    const uint index = hg_vertex(term, dense, table_size, c);
    float dot = 0.0f;
    for (uint f = 0; f < HG_FEATURES; ++f) dot += dy[f] * t[(size_t)index * HG_FEATURES + f];
    for (uint d = 0; d < HG_DIMS; ++d) {
      float w = ((c >> d) & 1u) ? 1.0f : -1.0f;
      for (uint e = 0; e < HG_DIMS; ++e)
        if (e != d) w *= w1[e][(c >> e) & 1u];
      grad[d] += dot * w * du[d];
    }
  }
}

// One work-item per (network, row), every level in order (GPUs).
__kernel void hashgrid_backward_positions(__global const float* restrict positions,
                                          __global const float* restrict table,
                                          __global const float* restrict dout,
                                          __constant float* res, __constant float* res_t,
                                          __global float* restrict dpositions, uint nets, uint rows,
                                          uint levels, uint table_size, float4 inv_bound, int accumulate) {
  const uint i = get_global_id(0);
  if (i >= nets * rows) return;
  const uint b = i / rows;
  float grad[HG_DIMS];
  for (uint d = 0; d < HG_DIMS; ++d) grad[d] = 0.0f;
  for (uint l = 0; l < levels; ++l)
    hg_position_grad_level(positions + (size_t)i * HG_DIMS,
                           table + ((size_t)b * levels + l) * table_size * HG_FEATURES,
                           dout + (size_t)i * levels * HG_FEATURES + l * HG_FEATURES, res, res_t, l,
                           table_size, inv_bound, grad);
  __global float* o = dpositions + (size_t)i * HG_DIMS;
  for (uint d = 0; d < HG_DIMS; ++d) o[d] = accumulate ? o[d] + grad[d] : grad[d];
}

// The same in two passes (CPUs, with the ordered table backward): one work-item per
// (network, level, row), rows fastest as in the forward, so that the items a CPU thread runs
// in turn read one level's table (its cache holds one level's, not every level's), each
// writing its level's part to partial [L, B, M, D]; reduce.cl's colsum_finish then adds a
// row's levels in order.
__kernel void hashgrid_backward_positions_levels(__global const float* restrict positions,
                                                 __global const float* restrict table,
                                                 __global const float* restrict dout,
                                                 __constant float* res, __constant float* res_t,
                                                 __global float* restrict partial, uint nets, uint rows,
                                                 uint levels, uint table_size, float4 inv_bound) {
  const uint i = get_global_id(0);
  if (i >= nets * levels * rows) return;
  const uint r = i % rows, l = (i / rows) % levels, b = i / (rows * levels);
  const size_t row = (size_t)b * rows + r;
  float grad[HG_DIMS];
  for (uint d = 0; d < HG_DIMS; ++d) grad[d] = 0.0f;
  hg_position_grad_level(positions + row * HG_DIMS, table + ((size_t)b * levels + l) * table_size * HG_FEATURES,
                         dout + row * levels * HG_FEATURES + l * HG_FEATURES, res, res_t, l, table_size,
                         inv_bound, grad);
  __global float* o = partial + ((size_t)l * nets * rows + row) * HG_DIMS;
  for (uint d = 0; d < HG_DIMS; ++d) o[d] = grad[d];
}

// ---- The parallel backward: fixed-point sums, exact in any order ---------------------------
// One work-item per (network, level, row) adds its 2^D F contributions to a table of 64-bit
// integers with atomics. Integer addition is associative, so the sum, and the run, is the
// same whatever order the atomics land in: as deterministic as the ordered backward above,
// with parallelism over rows (what a GPU needs). Contributions are scaled by 2^k, with k
// chosen from max |dout| so that no entry's sum can reach 2^60 (an entry receives at most
// weight 1 per row, so |sum| <= rows max |dout|); each is rounded to the nearest integer, an
// absolute error of at most 2^-(k+1) < 2^-60 rows max |dout| per contribution, far below
// float32's rounding of the ordered sum. The final float is the exact integer sum rounded once.
#ifdef cl_khr_int64_base_atomics
#pragma OPENCL EXTENSION cl_khr_int64_base_atomics : enable

// partial[i] = max |dout[e]| over e = i, i + parts, ... (max is exact in any order).
__kernel void hashgrid_absmax_partial(__global const float* dout, __global float* partial, uint n,
                                      uint parts) {
  const uint i = get_global_id(0);
  if (i >= parts) return;
  float m = 0.0f;
  for (uint e = i; e < n; e += parts) m = fmax(m, fabs(dout[e]));
  partial[i] = m;
}

// partial[0] = max of partial[0 .. parts): a single work-item.
__kernel void hashgrid_absmax_finish(__global float* partial, uint parts) {
  if (get_global_id(0) != 0) return;
  float m = partial[0];
  for (uint p = 1; p < parts; ++p) m = fmax(m, partial[p]);
  partial[0] = m;
}

// The scale exponent k: rows max|dout| 2^k < 2^60 (frexp: rows max|dout| < 2^e; the float
// product may round down by 2^-24 relative, which the headroom to 2^63 absorbs).
inline int hg_fixed_exponent(float absmax, uint rows) {
  if (!(absmax > 0.0f) || isinf(absmax)) return 0;
  int e;
  frexp((float)rows * absmax, &e);
  return 60 - e;
}

__kernel void hashgrid_backward_atomic(__global const float* positions, __global const float* dout,
                                       __constant float* res, __constant float* res_t,
                                       __global long* acc, __global const float* absmax,
                                       uint nets, uint rows, uint levels, uint table_size,
                                       float4 inv_bound) {
  const uint i = get_global_id(0);
  if (i >= nets * levels * rows) return;
  const uint r = i % rows, l = (i / rows) % levels, b = i / (rows * levels);
  const int k = hg_fixed_exponent(absmax[0], rows);
  uint v[HG_CORNERS];
  float w[HG_CORNERS];
  hg_corners(positions, b, rows, r, l, res, res_t, table_size, inv_bound, v, w);
  __global const float* dy = dout + ((size_t)b * rows + r) * levels * HG_FEATURES + l * HG_FEATURES;
  __global long* g = acc + ((size_t)b * levels + l) * table_size * HG_FEATURES;
  for (uint c = 0; c < HG_CORNERS; ++c)
    for (uint f = 0; f < HG_FEATURES; ++f) {
      const long q = convert_long_rte(ldexp(w[c] * dy[f], k));
      if (q != 0) atom_add(&g[(size_t)v[c] * HG_FEATURES + f], q);
    }
}

// dtable[e] (+)= acc[e] 2^-k, for every entry of every network and level.
__kernel void hashgrid_backward_fixed_to_float(__global const long* acc, __global const float* absmax,
                                               __global float* dtable, uint n, uint rows,
                                               int accumulate) {
  const uint e = get_global_id(0);
  if (e >= n) return;
  const float v = ldexp(convert_float(acc[e]), -hg_fixed_exponent(absmax[0], rows));
  dtable[e] = accumulate ? dtable[e] + v : v;
}
#else
// Without 64-bit atomics the host runs the ordered backward (hash_backward_choice).
#endif

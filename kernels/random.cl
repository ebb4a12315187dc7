// Counter-based random numbers (Philox4x32-10, Salmon et al. 2011, "Parallel random numbers:
// as easy as 1, 2, 3"): a draw is a pure function of (key, counter), so any work-item makes
// its own numbers, a run is bit-reproducible on a device, and resuming at step n draws what
// the uninterrupted run drew there. Value g of a draw is element g % 4 of the block made from
// the counter (g / 4, g / 2^34, counter_lo, counter_hi) under the key (seed, stream).

#define PHILOX_M0 0xD2511F53u
#define PHILOX_M1 0xCD9E8D57u
#define PHILOX_W0 0x9E3779B9u
#define PHILOX_W1 0xBB67AE85u

inline uint4 philox4x32_10(uint4 c, uint2 k) {
  for (int round = 0; round < 10; ++round) {
    if (round > 0) {
      k.x += PHILOX_W0;
      k.y += PHILOX_W1;
    }
    const uint hi0 = mul_hi(PHILOX_M0, c.x), lo0 = PHILOX_M0 * c.x;
    const uint hi1 = mul_hi(PHILOX_M1, c.z), lo1 = PHILOX_M1 * c.z;
    c = (uint4)(hi1 ^ c.y ^ k.x, lo1, hi0 ^ c.w ^ k.y, lo0);
  }
  return c;
}

// [0, 1) and (0, 1] from the top 24 bits: every value exact in float32.
inline float bits_to_unit(uint x) { return (float)(x >> 8) * 0x1.0p-24f; }
inline float bits_to_unit_open0(uint x) { return (float)((x >> 8) + 1u) * 0x1.0p-24f; }

// Value i of a draw laid out as rows of `cols` inside rows of `global_cols` starting at column
// `col_offset` (a slice of a larger draw: a rank's share of the rays): its global index g picks
// element g % 4 of the block g / 4.
inline ulong random_index(uint i, uint cols, uint global_cols, uint col_offset) {
  return (ulong)(i / cols) * global_cols + col_offset + i % cols;
}

inline uint4 random_block(ulong g, uint seed, uint stream, uint counter_lo, uint counter_hi) {
  return philox4x32_10((uint4)((uint)(g >> 2), (uint)(g >> 34), counter_lo, counter_hi), (uint2)(seed, stream));
}

inline uint pick(uint4 r, uint k) { return k == 0 ? r.x : k == 1 ? r.y : k == 2 ? r.z : r.w; }

// out[i] = scale * U[0, 1), i < n.
__kernel void random_uniform(__global float* out, uint n, uint cols, uint global_cols, uint col_offset,
                             uint seed, uint stream, uint counter_lo, uint counter_hi, float scale) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  const ulong g = random_index(i, cols, global_cols, col_offset);
  out[i] = scale * bits_to_unit(pick(random_block(g, seed, stream, counter_lo, counter_hi), (uint)(g & 3)));
}

// out[i] = scale * N(0, 1) by Box-Muller on the pairs (x, y) and (z, w) of a block: elements
// 0 and 2 take the cosine, 1 and 3 the sine. Full-precision maths (not native_), so every
// device agrees with the float64 reference to a few ulp.
__kernel void random_normal(__global float* out, uint n, uint cols, uint global_cols, uint col_offset,
                            uint seed, uint stream, uint counter_lo, uint counter_hi, float scale) {
  const uint i = get_global_id(0);
  if (i >= n) return;
  const ulong g = random_index(i, cols, global_cols, col_offset);
  const uint4 r = random_block(g, seed, stream, counter_lo, counter_hi);
  const uint k = (uint)(g & 3), pair = k >> 1;
  const float rad = sqrt(-2.0f * log(bits_to_unit_open0(pick(r, 2 * pair))));
  const float theta = 6.283185307179586f * bits_to_unit(pick(r, 2 * pair + 1));
  out[i] = scale * rad * ((k & 1) ? sin(theta) : cos(theta));
}

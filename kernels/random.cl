// Counter-based random numbers (Philox4x32-10, Salmon et al. 2011, "Parallel random numbers:
// as easy as 1, 2, 3"): a draw is a pure function of (key, counter), so any work-item makes
// its own numbers, a run is bit-reproducible on a device, and resuming at step n draws what
// the uninterrupted run drew there. Work-item j makes values 4j .. 4j + 3 from the counter
// (j, 0, counter_lo, counter_hi) under the key (seed, stream).

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

inline void store4(__global float* out, uint n, uint j, float4 v) {
  const uint at = 4u * j;
  if (at < n) out[at] = v.x;
  if (at + 1u < n) out[at + 1u] = v.y;
  if (at + 2u < n) out[at + 2u] = v.z;
  if (at + 3u < n) out[at + 3u] = v.w;
}

// out[i] = scale * U[0, 1), i < n; one work-item per 4 values.
__kernel void random_uniform(__global float* out, uint n, uint seed, uint stream, uint counter_lo,
                             uint counter_hi, float scale) {
  const uint j = get_global_id(0);
  if (4u * j >= n) return;
  const uint4 r = philox4x32_10((uint4)(j, 0u, counter_lo, counter_hi), (uint2)(seed, stream));
  store4(out, n, j,
         scale * (float4)(bits_to_unit(r.x), bits_to_unit(r.y), bits_to_unit(r.z), bits_to_unit(r.w)));
}

// out[i] = scale * N(0, 1) by Box-Muller on the pairs (x, y) and (z, w); full-precision maths
// (not native_), so every device agrees with the float64 reference to a few ulp.
__kernel void random_normal(__global float* out, uint n, uint seed, uint stream, uint counter_lo,
                            uint counter_hi, float scale) {
  const uint j = get_global_id(0);
  if (4u * j >= n) return;
  const uint4 r = philox4x32_10((uint4)(j, 0u, counter_lo, counter_hi), (uint2)(seed, stream));
  const float two_pi = 6.283185307179586f;
  const float ra = sqrt(-2.0f * log(bits_to_unit_open0(r.x))), ta = two_pi * bits_to_unit(r.y);
  const float rb = sqrt(-2.0f * log(bits_to_unit_open0(r.z))), tb = two_pi * bits_to_unit(r.w);
  store4(out, n, j, scale * (float4)(ra * cos(ta), ra * sin(ta), rb * cos(tb), rb * sin(tb)));
}

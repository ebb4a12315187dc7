// Rigid object motion (rigid_motion in motion.hpp): a sample of network b at time t is mapped
// from the scene into its object's canonical space,
//   y = R(a) (x - tau) + q,
// with x the sample in world coordinates, (a, tau) the motion at t (Euler angles about x, y, z,
// R = Rz Ry Rx, and a translation) interpolated linearly between the two frames around t, and
// q the object's pivot, the mean of its per-frame translations: where its canonical shape
// sits in the scene (a function of the trajectory, so nothing else is stored and it cannot
// drift apart from it). Layout: motion [B, F, 6], one row per frame (ax, ay, az, tx, ty, tz).
//
// In NDC (forward-facing scenes) the motion is applied in world coordinates, where it is rigid:
// x = ndc^-1(p), p' = ndc(y), with ndc(x) = (ax x/z, ay y/z, 1 + 2 near / z) as
// instance_points (sampling.cl), and the same clamps (NDC z = 1 is world z = -inf).

// Frame f0 and weight w of time t (frame i sits at t = 2 i / F - 1): the motion at t is
// (1 - w) P[f0] + w P[f0 + 1], clamped to the first and last frames.
inline void motion_frame(float t, uint frames, uint* f0, float* w) {
  if (frames < 2) {
    *f0 = 0;
    *w = 0.0f;
    return;
  }
  const float u = clamp((t + 1.0f) * 0.5f * (float)frames, 0.0f, (float)(frames - 1));
  uint f = (uint)floor(u);
  if (f > frames - 2) f = frames - 2;
  *f0 = f;
  *w = u - (float)f;
}

inline void motion_params(__global const float* P, uint f0, float w, uint frames, float* m) {
  __global const float* a = P + (size_t)f0 * 6;
  __global const float* b = P + (size_t)(frames < 2 ? f0 : f0 + 1) * 6;
  for (int j = 0; j < 6; ++j) m[j] = (1.0f - w) * a[j] + w * b[j];
}

// q = the mean of the F translations (summed in frame order).
inline void motion_pivot(__global const float* P, uint frames, float* q) {
  q[0] = q[1] = q[2] = 0.0f;
  for (uint f = 0; f < frames; ++f)
    for (int k = 0; k < 3; ++k) q[k] += P[(size_t)f * 6 + 3 + k];
  for (int k = 0; k < 3; ++k) q[k] /= (float)frames;
}

// R = Rz(c) Ry(b) Rx(a) and its three partial derivatives (row-major 3x3 each).
inline void motion_rotation(const float* m, float* R, float* dR) {
  const float ca = cos(m[0]), sa = sin(m[0]), cb = cos(m[1]), sb = sin(m[1]);
  const float cc = cos(m[2]), sc = sin(m[2]);
  const float rx[9] = {1, 0, 0, 0, ca, -sa, 0, sa, ca};
  const float ry[9] = {cb, 0, sb, 0, 1, 0, -sb, 0, cb};
  const float rz[9] = {cc, -sc, 0, sc, cc, 0, 0, 0, 1};
  const float drx[9] = {0, 0, 0, 0, -sa, -ca, 0, ca, -sa};
  const float dry[9] = {-sb, 0, cb, 0, 0, 0, -cb, 0, -sb};
  const float drz[9] = {-sc, -cc, 0, cc, -sc, 0, 0, 0, 0};
  float zy[9], dzy[9], zdy[9];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      float s0 = 0, s1 = 0, s2 = 0;
      for (int k = 0; k < 3; ++k) {
        s0 += rz[i * 3 + k] * ry[k * 3 + j];
        s1 += drz[i * 3 + k] * ry[k * 3 + j];
        s2 += rz[i * 3 + k] * dry[k * 3 + j];
      }
      zy[i * 3 + j] = s0;
      dzy[i * 3 + j] = s1;
      zdy[i * 3 + j] = s2;
    }
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      float r = 0, d0 = 0, d1 = 0, d2 = 0;
      for (int k = 0; k < 3; ++k) {
        r += zy[i * 3 + k] * rx[k * 3 + j];
        d0 += zy[i * 3 + k] * drx[k * 3 + j];
        d1 += zdy[i * 3 + k] * rx[k * 3 + j];
        d2 += dzy[i * 3 + k] * rx[k * 3 + j];
      }
      R[i * 3 + j] = r;
      dR[i * 3 + j] = d0;
      dR[9 + i * 3 + j] = d1;
      dR[18 + i * 3 + j] = d2;
    }
}

inline void motion_to_world(__global const float* q, int ndc, float ax, float ay, float near, float* x) {
  x[0] = q[0];
  x[1] = q[1];
  x[2] = q[2];
  if (ndc) {
    const float z = 2.0f * near / fmin(q[2] - 1.0f, -1e-6f);
    x[0] = q[0] * z / ax;
    x[1] = q[1] * z / ay;
    x[2] = z;
  }
}

// y -> NDC, and the Jacobian rows J (3x3, row-major) of that map (the identity when metric).
inline void motion_to_ndc(const float* y, int ndc, float ax, float ay, float near, float* out, float* J) {
  for (int k = 0; k < 9; ++k) J[k] = (k % 4 == 0) ? 1.0f : 0.0f;
  for (int k = 0; k < 3; ++k) out[k] = y[k];
  if (!ndc) return;
  const int clamped = !(y[2] < -1e-6f);
  const float z = clamped ? -1e-6f : y[2];
  const float iz = 1.0f / z;
  out[0] = ax * y[0] * iz;
  out[1] = ay * y[1] * iz;
  out[2] = 1.0f + 2.0f * near * iz;
  J[0] = ax * iz;
  J[1] = 0.0f;
  J[2] = clamped ? 0.0f : -ax * y[0] * iz * iz;
  J[3] = 0.0f;
  J[4] = ay * iz;
  J[5] = clamped ? 0.0f : -ay * y[1] * iz * iz;
  J[6] = 0.0f;
  J[7] = 0.0f;
  J[8] = clamped ? 0.0f : -2.0f * near * iz * iz;
}

// Row i of network b: the motion m at its time, R(m) and its partial derivatives dR, the
// offset d = x - tau of its world point x, and y = R d + q with its NDC image o (Jacobian J).
inline void motion_point(__global const float* positions, __global const float* times,
                         __global const float* motion, uint i, uint b, uint frames, int ndc, float ax,
                         float ay, float near, float* m, float* R, float* dR, float* d, float* o,
                         float* J) {
  __global const float* P = motion + (size_t)b * frames * 6;
  uint f0;
  float w, x[3], y[3], q[3];
  motion_frame(times[b], frames, &f0, &w);
  motion_params(P, f0, w, frames, m);
  motion_rotation(m, R, dR);
  motion_to_world(positions + (size_t)i * 3, ndc, ax, ay, near, x);
  motion_pivot(P, frames, q);
  for (int k = 0; k < 3; ++k) d[k] = x[k] - m[3 + k];
  for (int k = 0; k < 3; ++k) y[k] = R[k * 3] * d[0] + R[k * 3 + 1] * d[1] + R[k * 3 + 2] * d[2] + q[k];
  motion_to_ndc(y, ndc, ax, ay, near, o, J);
}

// One work-item per (network, row): out[b, r] = ndc(R (x - tau) + q).
__kernel void rigid_motion_forward(__global const float* positions, __global const float* times,
                                   __global const float* motion, __global float* out, uint nets,
                                   uint rows, uint frames, int ndc, float ax, float ay, float near) {
  const uint i = get_global_id(0);
  if (i >= nets * rows) return;
  float m[6], R[9], dR[27], d[3], o[3], J[9];
  motion_point(positions, times, motion, i, i / rows, frames, ndc, ax, ay, near, m, R, dR, d, o, J);
  for (int k = 0; k < 3; ++k) out[(size_t)i * 3 + k] = o[k];
}

// The gradient of one row with respect to the motion at its time and to the pivot,
// g[b, r, 0..8] (angles, translation, pivot).
__kernel void rigid_motion_row_grad(__global const float* positions, __global const float* times,
                                    __global const float* motion, __global const float* dout,
                                    __global float* g, uint nets, uint rows, uint frames,
                                    int ndc, float ax, float ay, float near) {
  const uint i = get_global_id(0);
  if (i >= nets * rows) return;
  float m[6], R[9], dR[27], d[3], o[3], J[9], gy[3];
  motion_point(positions, times, motion, i, i / rows, frames, ndc, ax, ay, near, m, R, dR, d, o, J);
  __global const float* dy = dout + (size_t)i * 3;
  for (int k = 0; k < 3; ++k) gy[k] = J[k] * dy[0] + J[3 + k] * dy[1] + J[6 + k] * dy[2];
  __global float* gi = g + (size_t)i * 9;
  for (int j = 0; j < 3; ++j) {
    float s = 0.0f;
    for (int k = 0; k < 3; ++k)
      s += gy[k] * (dR[j * 9 + k * 3] * d[0] + dR[j * 9 + k * 3 + 1] * d[1] + dR[j * 9 + k * 3 + 2] * d[2]);
    gi[j] = s;
  }
  for (int j = 0; j < 3; ++j) gi[3 + j] = -(R[j] * gy[0] + R[3 + j] * gy[1] + R[6 + j] * gy[2]);
  for (int j = 0; j < 3; ++j) gi[6 + j] = gy[j];
}

// d motion: one work-item per (network, parameter j of 6) sums its rows in order (a fixed
// order: bit-reproducible) and hands the sum to the two frames around the network's time by
// their interpolation weights; a translation also moves the pivot (the mean), so every frame
// gets 1/F of the pivot's sum too. Entries get their value, or add it when accumulating.
__kernel void rigid_motion_param_grad(__global const float* g, __global const float* times,
                                      __global float* dmotion, uint nets, uint rows, uint frames,
                                      int accumulate) {
  const uint i = get_global_id(0);
  if (i >= nets * 6) return;
  const uint b = i / 6, j = i % 6;
  float s = 0.0f, sq = 0.0f;
  __global const float* gb = g + (size_t)b * rows * 9;
  for (uint r = 0; r < rows; ++r) {
    s += gb[(size_t)r * 9 + j];
    if (j >= 3) sq += gb[(size_t)r * 9 + j + 3];
  }
  sq /= (float)frames;
  uint f0;
  float w;
  motion_frame(times[b], frames, &f0, &w);
  __global float* D = dmotion + (size_t)b * frames * 6 + j;
  for (uint f = 0; f < frames; ++f) {
    float v = sq;
    if (f == f0) v += (frames < 2 ? 1.0f : 1.0f - w) * s;
    if (frames >= 2 && f == f0 + 1) v += w * s;
    D[(size_t)f * 6] = accumulate ? D[(size_t)f * 6] + v : v;
  }
}

// Smoothness of each network's trajectory: loss = sum_b sum_f |P[f-1] - 2 P[f] + P[f+1]|^2 /
// (B (F - 2)) over frames 1..F-2 (second differences).
// One work-item computes the scalar (B F 6 terms: small), in order.
__kernel void motion_smoothness_forward(__global const float* motion, __global float* loss, uint nets,
                                        uint frames) {
  if (get_global_id(0) != 0) return;
  float s = 0.0f;
  for (uint b = 0; b < nets; ++b) {
    __global const float* P = motion + (size_t)b * frames * 6;
    for (uint f = 1; f + 1 < frames; ++f)
      for (int j = 0; j < 6; ++j) {
        const float d = P[(f - 1) * 6 + j] - 2.0f * P[f * 6 + j] + P[(f + 1) * 6 + j];
        s += d * d;
      }
  }
  loss[0] = frames > 2 ? s / (float)(nets * (frames - 2)) : 0.0f;
}

// d motion of the smoothness loss, one work-item per (network, frame, parameter).
__kernel void motion_smoothness_backward(__global const float* motion, __global const float* dloss,
                                         __global float* dmotion, uint nets, uint frames, int accumulate) {
  const uint i = get_global_id(0);
  if (i >= nets * frames * 6) return;
  const uint j = i % 6, f = (i / 6) % frames, b = i / (6 * frames);
  __global const float* P = motion + (size_t)b * frames * 6 + j;
  float v = 0.0f;
  if (frames > 2) {
    const float scale = 2.0f * dloss[0] / (float)(nets * (frames - 2));
    // f takes part in the second differences centred at f - 1 (weight 1), f (-2), f + 1 (1).
    for (int c = (int)f - 1; c <= (int)f + 1; ++c) {
      if (c < 1 || c + 1 >= (int)frames) continue;
      const float d = P[(c - 1) * 6] - 2.0f * P[c * 6] + P[(c + 1) * 6];
      v += (c == (int)f ? -2.0f : 1.0f) * d * scale;
    }
  }
  dmotion[i] = accumulate ? dmotion[i] + v : v;
}

// ---- Samples where the objects are (object_samples.hpp, sample_warp.hpp) ----
// The warp of a training step's samples from where the objects stand at their times: object
// b's pivot is at its motion's translation tau(times[b]) (the motion maps tau to the pivot),
// and its range is the depth fractions t = 1 + near / z of world z within reach * radius[b]
// of tau's. Then the knots (u, t) of the mixture (1 - share) even + share split evenly over
// the ranges; a range narrower than min_interval widened about its middle to it. One
// work-item (K <= kMaxWarpObjects, sample_warp.hpp's bound: a few hundred numbers). As
// sample_warp and depth_interval on the host.
#define kMaxWarpObjects 64

inline float depth_fraction(float z, float near) { return z < -near ? 1.0f + near / z : 0.0f; }

__kernel void object_sample_warp(__global const float* motion, __global const float* radius,
                                 __global const float* times, __global float* warp, uint K,
                                 uint frames, float near, float share, float reach,
                                 float min_interval) {
  if (get_global_id(0) != 0) return;
  float lo[kMaxWarpObjects], hi[kMaxWarpObjects];
  uint kept = 0;
  for (uint b = 0; b < K; ++b) {
    uint f0;
    float w, m[6];
    motion_frame(times[b], frames, &f0, &w);
    motion_params(motion + (size_t)b * frames * 6, f0, w, frames, m);
    const float r = reach * radius[b];
    float l = depth_fraction(m[5] + r, near), h = depth_fraction(m[5] - r, near);
    if (!(h > l)) continue;
    if (h - l < min_interval) {
      const float mid = 0.5f * (l + h);
      l = mid - 0.5f * min_interval;
      h = mid + 0.5f * min_interval;
    }
    l = fmax(l, 0.0f);
    h = fmin(h, 1.0f);
    if (h > l) {
      lo[kept] = l;
      hi[kept] = h;
      ++kept;
    }
  }
  const float even = kept ? 1.0f - share : 1.0f, each = kept ? share / (float)kept : 0.0f;
  float bounds[2 * kMaxWarpObjects + 2];
  uint n = 0;
  bounds[n++] = 0.0f;
  bounds[n++] = 1.0f;
  for (uint b = 0; b < kept; ++b) {
    bounds[n++] = lo[b];
    bounds[n++] = hi[b];
  }
  for (uint i = 1; i < n; ++i)  // insertion sort, then drop repeats
    for (uint j = i; j > 0 && bounds[j - 1] > bounds[j]; --j) {
      const float s = bounds[j];
      bounds[j] = bounds[j - 1];
      bounds[j - 1] = s;
    }
  uint u = 1;
  for (uint i = 1; i < n; ++i)
    if (bounds[i] != bounds[u - 1]) bounds[u++] = bounds[i];
  float cdf[2 * kMaxWarpObjects + 2];
  cdf[0] = 0.0f;
  for (uint i = 0; i + 1 < u; ++i) {
    const float a = bounds[i], z = bounds[i + 1], mid = 0.5f * (a + z);
    float density = even;
    for (uint b = 0; b < kept; ++b)
      if (mid > lo[b] && mid < hi[b]) density += each / (hi[b] - lo[b]);
    cdf[i + 1] = cdf[i] + density * (z - a);
  }
  const uint W = 2 * K + 2;
  for (uint i = 0; i < W; ++i) {
    warp[2 * i] = i < u ? (i + 1 == u ? 1.0f : cdf[i] / cdf[u - 1]) : 1.0f;
    warp[2 * i + 1] = i < u ? bounds[i] : 1.0f;
  }
}

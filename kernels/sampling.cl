// Ray generation (pinhole, OpenGL axes, optional LLFF NDC) and stratified samples along the
// rays. Forward only: rays and samples are data for the NeRF MLPs, not trained.

// cams [N, 16]: fx, fy, cx, cy, then the camera-to-world matrix, 3x4 row-major.
// Pixel (i, j) looks along ((i - cx) / fx, -(j - cy) / fy, -1) in camera space (camera.hpp).
// Outputs [N, R, 3]: origin and direction (world, or NDC when ndc != 0), and the unit world
// direction (the view direction the reference feeds the colour head, taken before NDC).
//
// NDC as the reference's ndc_rays (forward-facing scenes, near plane `near`, principal point
// at the image centre so that W / (2 f) = cx / fx): the origin moves onto the plane
// z = -near, then
//   o' = (-fx/cx ox/oz, -fy/cy oy/oz, 1 + 2 near / oz)
//   d' = (-fx/cx (dx/dz - ox/oz), -fy/cy (dy/dz - oy/oz), -2 near / oz)
__kernel void rays_generate(__global const float* pixels, __global const float* cams,
                            __global float* origins, __global float* dirs,
                            __global float* viewdirs, uint R, uint N, int ndc, float near) {
  const uint r = get_global_id(0), n = get_global_id(1);
  if (r >= R || n >= N) return;
  __global const float* c = cams + n * 16;
  __global const float* m = c + 4;
  const float u = (pixels[r * 2] - c[2]) / c[0];
  const float v = -(pixels[r * 2 + 1] - c[3]) / c[1];
  float d[3], o[3];
  for (int k = 0; k < 3; ++k) {
    d[k] = m[k * 4] * u + m[k * 4 + 1] * v - m[k * 4 + 2];
    o[k] = m[k * 4 + 3];
  }
  const float inv_norm = rsqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  const size_t at = ((size_t)n * R + r) * 3;
  for (int k = 0; k < 3; ++k) viewdirs[at + k] = d[k] * inv_norm;
  if (ndc) {
    const float t = -(near + o[2]) / d[2];
    for (int k = 0; k < 3; ++k) o[k] += t * d[k];
    const float ax = -c[0] / c[2], ay = -c[1] / c[3];
    const float ox = o[0] / o[2], oy = o[1] / o[2];
    const float nd[3] = {ax * (d[0] / d[2] - ox), ay * (d[1] / d[2] - oy), -2.0f * near / o[2]};
    const float no[3] = {ax * ox, ay * oy, 1.0f + 2.0f * near / o[2]};
    for (int k = 0; k < 3; ++k) {
      d[k] = nd[k];
      o[k] = no[k];
    }
  }
  for (int k = 0; k < 3; ++k) {
    origins[at + k] = o[k];
    dirs[at + k] = d[k];
  }
}

// A warp of the samples' depth (sample_warp.hpp): W knots (u, t) of a piecewise-linear,
// increasing map of [0, 1] onto itself, the inverse of the samples' cumulative density, so that
// evenly spread u put more samples where the map is flat. W = 0: no warp.
inline float warp_depth(__global const float* warp, uint W, float u) {
  for (uint j = 0; j + 1 < W; ++j) {
    const float u0 = warp[2 * j], u1 = warp[2 * j + 2];
    if (u <= u1 || j + 2 == W) {
      const float t0 = warp[2 * j + 1], t1 = warp[2 * j + 3];
      return u1 > u0 ? t0 + (t1 - t0) * clamp((u - u0) / (u1 - u0), 0.0f, 1.0f) : t1;
    }
  }
  return u;
}

// Depth of sample i of ray r: the reference's stratified scheme. Without jitter the samples
// are linspace(near, far, S); with it, sample i is uniform (u = jitter[r, i]) between the
// midpoints to its neighbours (the first and last keep their outer bound). With a warp the
// same fraction of [near, far] goes through warp_depth.
inline float sample_depth(__global const float* jitter, int use_jitter, uint r, uint i, uint S,
                          float near, float far, __global const float* warp, uint W) {
  const float step = S > 1 ? (far - near) / (float)(S - 1) : 0.0f;
  float t = near + step * (float)i;
  if (use_jitter) {
    const float lower = i > 0 ? t - 0.5f * step : t;
    const float upper = i + 1 < S ? t + 0.5f * step : t;
    t = lower + (upper - lower) * jitter[(size_t)r * S + i];
  }
  if (W == 0) return t;
  return near + (far - near) * warp_depth(warp, W, (t - near) / (far - near));
}

// z [R, S] and the spacing delta [N, R, S] = (z_{i+1} - z_i) |d_n|, 1e10 |d_n| for the last
// sample (as the reference's raw2outputs). One work-item per (sample, NeRF).
__kernel void sample_spacing(__global const float* dirs, __global const float* jitter,
                             __global float* z, __global float* delta, uint R, uint S, uint N,
                             float near, float far, int use_jitter, __global const float* warp,
                             uint W) {
  const uint e = get_global_id(0), n = get_global_id(1);
  if (e >= R * S || n >= N) return;
  const uint r = e / S, i = e % S;
  const float zi = sample_depth(jitter, use_jitter, r, i, S, near, far, warp, W);
  if (n == 0) z[e] = zi;
  __global const float* d = dirs + ((size_t)n * R + r) * 3;
  const float norm = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  const float gap = i + 1 < S ? sample_depth(jitter, use_jitter, r, i + 1, S, near, far, warp, W) - zi : 1e10f;
  delta[(size_t)n * R * S + e] = gap * norm;
}

// Positions o + z d and the per-sample unit view direction, for NeRFs [first, first + count)
// into a group's own tensors [count, R*S, 3] (the layout positional_encoding and a batched
// MLP read). One work-item per (sample, NeRF of the group).
__kernel void sample_points(__global const float* origins, __global const float* dirs,
                            __global const float* viewdirs, __global const float* jitter,
                            __global float* positions, __global float* sample_viewdirs, uint R,
                            uint S, uint first, uint count, float near, float far,
                            int use_jitter, __global const float* warp, uint W) {
  const uint e = get_global_id(0), g = get_global_id(1);
  if (e >= R * S || g >= count) return;
  const uint r = e / S, i = e % S, n = first + g;
  const float zi = sample_depth(jitter, use_jitter, r, i, S, near, far, warp, W);
  const size_t ray = ((size_t)n * R + r) * 3, out = ((size_t)g * R * S + e) * 3;
  for (int k = 0; k < 3; ++k) {
    positions[out + k] = origins[ray + k] + zi * dirs[ray + k];
    sample_viewdirs[out + k] = viewdirs[ray + k];
  }
}

// Sample positions of a render ray seen by placed object instances (composition): each
// instance b carries the inverse of its placement, a world-to-object 3x4 map xf[b], so the
// object NeRF is queried where the moved object would be. In NDC the map is taken in world
// coordinates: p = ndc^-1(q), p' = xf[b] p, q' = ndc(p'), with ndc(p) = (ax px/pz, ay py/pz,
// 1 + 2 near / pz) as rays_generate. One work-item per (sample, instance).
__kernel void instance_points(__global const float* positions, __global const float* xf,
                              __global float* out, uint M, uint B, int ndc, float ax, float ay,
                              float near) {
  const uint e = get_global_id(0), b = get_global_id(1);
  if (e >= M || b >= B) return;
  __global const float* q = positions + (size_t)e * 3;
  float p[3] = {q[0], q[1], q[2]};
  if (ndc) {
    // q_z = 1 is the far end of NDC (world z = -inf): keep it finite, behind every object.
    const float pz = 2.0f * near / fmin(p[2] - 1.0f, -1e-6f);
    p[0] = q[0] * pz / ax;
    p[1] = q[1] * pz / ay;
    p[2] = pz;
  }
  __global const float* m = xf + (size_t)b * 12;
  float r[3];
  for (int k = 0; k < 3; ++k) r[k] = m[k * 4] * p[0] + m[k * 4 + 1] * p[1] + m[k * 4 + 2] * p[2] + m[k * 4 + 3];
  if (ndc) {
    const float z = fmin(r[2], -1e-6f);  // points behind the NDC origin plane stay behind
    r[0] = ax * r[0] / z;
    r[1] = ay * r[1] / z;
    r[2] = 1.0f + 2.0f * near / z;
  }
  __global float* o = out + ((size_t)b * M + e) * 3;
  for (int k = 0; k < 3; ++k) o[k] = r[k];
}

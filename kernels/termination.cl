// Early ray termination on the device (view_renderer.cpp): a chunk of rays is rendered in
// segments of samples; after each segment every open ray adds its segment's composite scaled
// by the transmittance left before it, C = C_1 + T_1 C_2 + ..., and carries T on; before the
// next segment a ray stays open while T >= below. Only per-chunk results and two counts cross
// to the host.

// T[r] = 1 for the chunk's n real rays, 0 for padding (closed from the start); no ray open
// yet; the accumulated outputs start at 0.
__kernel void termination_start(__global float* T, __global uchar* open, __global float* rgb,
                                __global float* depth, __global float* acc, __global float* mask,
                                uint rays, uint n, uint nerfs) {
  const uint r = get_global_id(0);
  if (r >= rays) return;
  T[r] = r < n ? 1.0f : 0.0f;
  open[r] = 0;
  rgb[3 * r] = rgb[3 * r + 1] = rgb[3 * r + 2] = 0.0f;
  depth[r] = acc[r] = 0.0f;
  for (uint k = 0; k < nerfs; ++k) mask[k * rays + r] = 0.0f;
}

// open[r] = T[r] >= below, and was_open[r] keeps the previous flag for the count below.
__kernel void termination_open(__global const float* T, __global uchar* open,
                               __global uchar* was_open, uint rays, float below) {
  const uint r = get_global_id(0);
  if (r >= rays) return;
  was_open[r] = open[r];
  open[r] = T[r] >= below;
}

// counts[0] = open rays, counts[1] = rays open before and closed now (when `first` is 0); a
// single work-item over one chunk's rays (a few thousand), in order.
__kernel void termination_count(__global const uchar* open, __global const uchar* was_open,
                                __global uint* counts, uint rays, int first) {
  if (get_global_id(0) != 0) return;
  uint live = 0, stopped = 0;
  for (uint r = 0; r < rays; ++r) {
    live += open[r];
    stopped += !first && was_open[r] && !open[r];
  }
  counts[0] = live;
  counts[1] = stopped;
}

// After a segment: each open ray adds T times the segment's composite (colour, depth,
// accumulated opacity, per-NeRF masks) and multiplies T by what the segment let through,
// 1 - acc (up to float rounding and the 1e-10 per sample of render.cl's product; clamped, as
// rounding may push acc past 1).
__kernel void termination_accumulate(__global const float* seg_rgb, __global const float* seg_depth,
                                     __global const float* seg_acc, __global const float* seg_mask,
                                     __global const uchar* open, __global float* T,
                                     __global float* rgb, __global float* depth,
                                     __global float* acc, __global float* mask, uint rays,
                                     uint nerfs) {
  const uint r = get_global_id(0);
  if (r >= rays || !open[r]) return;
  const float t = T[r];
  for (uint j = 0; j < 3; ++j) rgb[3 * r + j] += t * seg_rgb[3 * r + j];
  depth[r] += t * seg_depth[r];
  acc[r] += t * seg_acc[r];
  for (uint k = 0; k < nerfs; ++k) mask[k * rays + r] += t * seg_mask[k * rays + r];
  T[r] = t * fmax(0.0f, 1.0f - seg_acc[r]);
}

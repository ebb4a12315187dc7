#pragma once
// The layout shared by the losses that walk each NeRF's samples along a ray with its own
// transmittance (distortion, free space): raw [N, R*S, C] (sigma in channel 3), z [R, S],
// delta [R, S] or [N, R, S], noise [N, R*S] (optional), NeRFs from `first` on taking part.
#include <string>

#include "nova/runtime/error.hpp"
#include "nova/render/render_composite.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova::detail {

struct RaySampleLayout {
  size_t nerfs = 0, rays = 0, samples = 0, channels = 0, first = 0;
  bool per_nerf_delta = false;

  unsigned delta_stride() const { return per_nerf_delta ? u32(rays * samples, "rays x samples") : 0u; }
  size_t pairs() const { return nerfs * rays; }
  // The mean over the (NeRF, ray) pairs taking part.
  float pair_scale() const { return 1.0f / static_cast<float>((nerfs - first) * rays); }
};

// Checks the shapes (Error naming `op` on the first problem) and that the data inputs take no
// gradient.
inline RaySampleLayout ray_sample_layout(const std::string& op, Tensor raw, Tensor delta, Tensor z,
                                         Tensor noise, size_t first) {
  const auto bad = [&](const std::string& what) { throw Error(op + ": " + what, kExitInternal); };
  const auto d = as_batched(raw.shape(), op);
  if (first >= d.batch)
    bad("first NeRF " + std::to_string(first) + " leaves none of raw's " + std::to_string(d.batch));
  if (d.cols < static_cast<size_t>(kRawChannels))
    bad("raw needs at least 5 channels, got " + raw.shape().str());
  const Shape& zs = z.shape();
  if (zs.rank() != 2 || zs[0] * zs[1] != d.rows) bad("z must be [R, S] of raw's rows, got " + zs.str());
  const size_t dn = delta.shape().numel();
  if (dn != d.rows && dn != d.batch * d.rows) bad("delta " + delta.shape().str() + " does not fit raw");
  if (noise.valid() && noise.shape().numel() != d.batch * d.rows)
    bad("noise " + noise.shape().str() + " does not fit raw");
  for (const Tensor& t : {delta, z, noise})
    if (t.valid() && t.info().requires_grad) bad(t.info().name + " is data and cannot take a gradient");
  return {d.batch, zs[0], zs[1], d.cols, first, dn != d.rows};
}

}  // namespace nova::detail

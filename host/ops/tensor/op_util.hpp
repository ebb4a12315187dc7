#pragma once
// Small helpers shared by the op implementations.
#include <limits>
#include <string>

#include "nova/runtime/error.hpp"
#include "nova/graph/graph.hpp"

namespace nova::detail {

// Kernels index with 32-bit integers (fast on every device); sizes beyond that are refused.
inline unsigned u32(size_t v, const char* what) {
  if (v > std::numeric_limits<unsigned>::max())
    throw Error(std::string(what) + " = " + std::to_string(v) + " exceeds 32-bit indexing",
                kExitUsage);
  return static_cast<unsigned>(v);
}

// An op's refusal of how it was built (a programming error, not a user's input).
[[noreturn]] inline void bad_op(const std::string& op, const std::string& what) {
  throw Error(op + ": " + what, kExitInternal);
}

// Refuses a tensor the op reads as data (targets, masks, weights) that asks for a gradient.
inline void require_data(const std::string& op, const Tensor& t) {
  if (t.valid() && t.info().requires_grad) bad_op(op, "'" + t.info().name + "' is data and cannot take a gradient");
}

// Split a [B, M, N] or [M, N] shape into (batch, rows, cols).
struct Matrix3 {
  size_t batch, rows, cols;
};
inline Matrix3 as_batched(const Shape& s, const std::string& op) {
  if (s.rank() == 2) return {1, s[0], s[1]};
  if (s.rank() == 3) return {s[0], s[1], s[2]};
  throw Error(op + ": expected a [M, N] or [B, M, N] tensor, got " + s.str(), kExitInternal);
}

// The layout of the per-object alpha losses (alpha_loss, sparsity_loss, alpha_loss_outside):
// raw [N, R * S, C >= 5] with N >= 2, masks [N, R], delta [R * S] or [N, R * S], noise
// [N, R * S] or none; masks, delta and noise are data. Errors name `op`.
struct AlphaLossLayout {
  size_t nerfs, rays, samples, cols;
  bool per_nerf_delta;
};
inline AlphaLossLayout alpha_loss_layout(const std::string& op, const Tensor& raw, const Tensor& delta,
                                         const Tensor& masks, const Tensor& noise, size_t min_cols) {
  const auto bad = [&](const std::string& what) { throw Error(op + ": " + what, kExitInternal); };
  const Matrix3 d = as_batched(raw.shape(), op);
  if (d.cols < min_cols) bad("raw needs at least 5 channels, got " + raw.shape().str());
  if (d.batch < 2) bad("needs at least one object NeRF (N >= 2), raw is " + raw.shape().str());
  if (masks.shape().rank() != 2 || masks.shape()[0] != d.batch)
    bad("masks must be [N, R], got " + masks.shape().str());
  const size_t rays = masks.shape()[1];
  if (d.rows % rays) bad("masks " + masks.shape().str() + " do not fit raw " + raw.shape().str());
  const size_t dn = delta.shape().numel();
  if (dn != d.rows && dn != d.batch * d.rows) bad("delta " + delta.shape().str() + " does not fit");
  if (noise.valid() && noise.shape().numel() != d.batch * d.rows)
    bad("noise " + noise.shape().str() + " does not fit");
  for (const Tensor* t : {&delta, &masks, &noise})
    if (t->valid() && t->info().requires_grad)
      bad("'" + t->info().name + "' is data and cannot take a gradient");
  return {d.batch, rays, d.rows / rays, d.cols, dn != d.rows};
}

// Number of partial sums for a two-stage reduction over n elements: enough work-items to
// fill a GPU, few enough that the final single-item pass stays trivial.
inline size_t reduction_parts(size_t n) {
  size_t parts = 1;
  while (parts < 4096 && parts * 256 < n) parts *= 2;
  return parts;
}

}  // namespace nova::detail

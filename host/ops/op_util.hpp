#pragma once
// Small helpers shared by the op implementations.
#include <limits>
#include <string>

#include "nova/error.hpp"
#include "nova/graph.hpp"

namespace nova::detail {

// Kernels index with 32-bit integers (fast on every device); sizes beyond that are refused.
inline unsigned u32(size_t v, const char* what) {
  if (v > std::numeric_limits<unsigned>::max())
    throw Error(std::string(what) + " = " + std::to_string(v) + " exceeds 32-bit indexing",
                kExitUsage);
  return static_cast<unsigned>(v);
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

// Number of partial sums for a two-stage reduction over n elements: enough work-items to
// fill a GPU, few enough that the final single-item pass stays trivial.
inline size_t reduction_parts(size_t n) {
  size_t parts = 1;
  while (parts < 4096 && parts * 256 < n) parts *= 2;
  return parts;
}

}  // namespace nova::detail

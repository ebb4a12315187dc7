// The smallest value in the square of half-width `reach` about each cell of a width x height
// grid (row-major), the square cut at the grid's edges: separably, along each row and then
// along each column. What the ring about the objects' masks (pixel_batch.cpp), the nearest
// depth within a mask (motion_alignment.cpp) and the bands about a silhouette
// (disparity_edges.cpp) read; square_max is the largest value, the same way.
#pragma once

#include <algorithm>
#include <cstddef>
#include <limits>
#include <vector>

namespace nova::detail {

// Along each of `lines` lines (`pitch` cells apart) of `n` cells (`stride` apart): the
// smallest value within `r` cells of each cell on its line.
inline std::vector<float> line_min(const std::vector<float>& v, ptrdiff_t n, ptrdiff_t stride, ptrdiff_t lines,
                                   ptrdiff_t pitch, ptrdiff_t r) {
  std::vector<float> out(v.size(), std::numeric_limits<float>::infinity());
  for (ptrdiff_t l = 0; l < lines; ++l)
    for (ptrdiff_t i = 0; i < n; ++i) {
      float m = std::numeric_limits<float>::infinity();
      for (ptrdiff_t j = std::max<ptrdiff_t>(0, i - r); j <= std::min(n - 1, i + r); ++j)
        m = std::min(m, v[static_cast<size_t>(l * pitch + j * stride)]);
      out[static_cast<size_t>(l * pitch + i * stride)] = m;
    }
  return out;
}

inline std::vector<float> square_min(const std::vector<float>& v, size_t width, size_t height, int reach) {
  const ptrdiff_t r = std::max(reach, 0), w = static_cast<ptrdiff_t>(width), h = static_cast<ptrdiff_t>(height);
  return line_min(line_min(v, w, 1, h, w, r), h, w, w, 1, r);  // rows, then columns
}

// Negation is exact, so this is the largest value bit for bit.
inline std::vector<float> square_max(const std::vector<float>& v, size_t width, size_t height, int reach) {
  std::vector<float> out(v.size());
  for (size_t i = 0; i < v.size(); ++i) out[i] = -v[i];
  out = square_min(out, width, height, reach);
  for (float& x : out) x = -x;
  return out;
}

}  // namespace nova::detail

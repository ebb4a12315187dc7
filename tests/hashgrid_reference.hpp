#pragma once
// Float64 reference of the hash encoding (include/nova/ops/encoding/hash_encoding.hpp, kernels/hash_encoding.cl):
// the vertices each position reads with their weights, the encoding they sum to, and the
// positions the tests draw.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "harness.hpp"
#include "nova/ops/encoding/hash_encoding.hpp"

namespace nova::test {

// A grid of `levels` levels of `features` floats over 2^log2_size table entries per level,
// from min_res to max_res cells per dimension (the rest as HashGridConfig's defaults).
inline HashGridConfig grid_config(int levels, int features, int log2_size, int min_res, int max_res) {
  HashGridConfig c;
  c.levels = levels;
  c.features = features;
  c.log2_size = log2_size;
  c.min_resolution = min_res;
  c.max_resolution = max_res;
  return c;
}

// Every vertex a float64 evaluation of the encoding reads: visit(row, level, table row,
// weight) for each corner of each level of each of `rows` positions [M, D] (one network).
template <class Visit>
void for_each_vertex(const std::vector<float>& pos, size_t rows, size_t dims, const HashGridConfig& c, Visit visit) {
  const std::vector<float> res = hash_grid_resolutions(c), res_t = hash_grid_time_resolutions(c);
  const uint64_t T = uint64_t{1} << c.log2_size;
  const uint32_t primes[4] = {1u, 2654435761u, 805459861u, 3674653429u};
  for (size_t r = 0; r < rows; ++r) {
    for (int l = 0; l < c.levels; ++l) {
      // The 4th coordinate is time: on [-1, 1] with its own cell count.
      double R[4], bound[4];
      for (size_t d = 0; d < dims; ++d) {
        const bool time = d == 3;
        R[d] = time ? res_t[l] : res[l];
        bound[d] = time ? 1.0 : c.half_size(static_cast<int>(d));
      }
      double vertices = 1;
      for (size_t d = 0; d < dims; ++d) vertices *= R[d] + 1;
      const bool dense = vertices <= static_cast<double>(T);
      uint32_t cell[4];
      double frac[4];
      for (size_t d = 0; d < dims; ++d) {
        // With `extend`, hashed levels place a point beyond the box in cells of their own
        // (a cell before it wraps modulo 2^32); time and dense levels clamp.
        const bool extend = c.extend && !dense && d != 3;
        const double v = 0.5 * (pos[r * dims + d] / bound[d] + 1.0);
        const double u = (extend ? v : std::clamp(v, 0.0, 1.0)) * R[d];
        const double f = extend ? std::floor(u) : std::min(std::floor(u), R[d] - 1);
        cell[d] = static_cast<uint32_t>(static_cast<int64_t>(f));
        frac[d] = u - f;
      }
      for (uint32_t corner = 0; corner < (1u << dims); ++corner) {
        double w = 1;
        uint64_t index = 0, stride = 1;
        uint32_t h = 0;
        for (size_t d = 0; d < dims; ++d) {
          const uint32_t bit = (corner >> d) & 1u, v = cell[d] + bit;
          w *= bit ? frac[d] : 1 - frac[d];
          index += v * stride;
          stride *= static_cast<uint64_t>(R[d]) + 1;
          h ^= v * primes[d];  // uint32 wrap-around, as the kernel
        }
        visit(r, l, dense ? index : (h & (T - 1)), w);
      }
    }
  }
}

// The derivative of each vertex weight of one position (D coordinates) along dimension `dim`,
// in cell units: visit(level, table row, dw) with dw the other dimensions' weights signed by
// the vertex's side along `dim` (times cells per unit of x gives d/dx). Positions strictly
// inside the box (no clamp, no extension).
template <class Visit>
void for_each_vertex_derivative(const std::vector<float>& pos, size_t dims, size_t dim, const HashGridConfig& c,
                                Visit visit) {
  // The vertices in for_each_vertex's order (corner c takes bit d of c along dimension d),
  // their derivative from the position's fractions.
  const std::vector<float> res = hash_grid_resolutions(c), res_t = hash_grid_time_resolutions(c);
  for (int l = 0; l < c.levels; ++l) {
    double frac[4];
    for (size_t d = 0; d < dims; ++d) {
      const double R = d == 3 ? res_t[l] : res[l];
      const double bound = d == 3 ? 1.0 : c.half_size(static_cast<int>(d));
      const double u = std::clamp(0.5 * (pos[d] / bound + 1.0), 0.0, 1.0) * R;
      frac[d] = u - std::min(std::floor(u), R - 1);
    }
    uint32_t corner = 0;
    for_each_vertex(pos, 1, dims, c, [&](size_t, int level, uint64_t row, double) {
      if (level != l) return;
      double dw = 1;
      for (size_t d = 0; d < dims; ++d) {
        const uint32_t bit = (corner >> d) & 1u;
        if (d == dim) dw *= bit ? 1.0 : -1.0;
        else dw *= bit ? frac[d] : 1 - frac[d];
      }
      ++corner;
      visit(l, row, dw);
    });
  }
}

// Float64 reference of one network: positions [M, D], table [L, T, F] -> [M, L * F].
inline std::vector<double> hash_reference(const std::vector<float>& pos, size_t rows, size_t dims,
                                   const std::vector<float>& table, const HashGridConfig& c) {
  const uint64_t T = uint64_t{1} << c.log2_size;
  std::vector<double> out(rows * c.levels * c.features, 0.0);
  for_each_vertex(pos, rows, dims, c, [&](size_t r, int l, uint64_t row, double w) {
    for (int f = 0; f < c.features; ++f)
      out[(r * c.levels + l) * c.features + f] += w * table[(l * T + row) * c.features + f];
  });
  return out;
}

// The same for `nets` networks: positions [nets, M, D], tables [nets, L, T, F] -> [nets, M, L * F].
inline std::vector<double> hash_reference(const std::vector<float>& pos, const std::vector<float>& tables, size_t rows,
                                          size_t dims, size_t nets, const HashGridConfig& c) {
  const size_t tsize = hash_grid_table_shape(c).numel();
  std::vector<double> ref;
  for (size_t b = 0; b < nets; ++b) {
    const std::vector<float> pb(pos.begin() + b * rows * dims, pos.begin() + (b + 1) * rows * dims);
    const std::vector<float> tb(tables.begin() + b * tsize, tables.begin() + (b + 1) * tsize);
    const std::vector<double> r = hash_reference(pb, rows, dims, tb, c);
    ref.insert(ref.end(), r.begin(), r.end());
  }
  return ref;
}


// Positions in [-1.3 b, 1.3 b] (some clamped) plus the exact box corners and centre.
inline std::vector<float> test_positions(size_t rows, size_t dims, float bound, unsigned seed) {
  std::vector<float> p = random_floats(rows * dims, -1.3f * bound, 1.3f * bound, seed);
  for (size_t d = 0; d < dims; ++d) {
    p[d] = bound;
    p[dims + d] = -bound;
    p[2 * dims + d] = 0.0f;
  }
  return p;
}

}  // namespace nova::test

#pragma once
// Random numbers made on the device by a counter-based generator (kernels/random.cl,
// Philox4x32-10): value i of a draw is a pure function of (seed, stream, counter, i). A graph
// draws its per-sample randomness (stratified jitter, density noise) with these ops instead
// of receiving it from the host, so nothing of per-sample size crosses the bus; the owner
// advances the counter once per run (the trainer sets it to the step), which keeps runs
// bit-reproducible and makes a resumed run draw exactly what the uninterrupted one drew.
#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "nova/graph/graph.hpp"

namespace nova {

// Shared between a graph's random ops and whoever runs the graph.
struct DrawCounter {
  uint64_t value = 0;
};

struct RandomStream {
  uint32_t seed = 0;
  uint32_t stream = 0;  // distinct draws of one graph take distinct streams
  std::shared_ptr<const DrawCounter> counter;
  // A slice of a larger draw: the tensor's rows (its last dimension's values) are columns
  // [col_offset, col_offset + cols) of rows `global_cols` long (0: the tensor's own width).
  // A rank of a data-parallel job that takes rays [a, b) of a step draws exactly what one
  // process drawing all rays draws for them.
  size_t global_cols = 0, col_offset = 0;
  // The row width the slice arithmetic uses (0: the tensor's last dimension); a [R, S] draw
  // sliced by rays reads as one row of R S values.
  size_t view_cols = 0;
};

// [shape] of scale * U[0, 1) (values multiples of 2^-24, so exact in float32).
Tensor random_uniform(Graph& g, const std::string& name, Shape shape, RandomStream rs, float scale = 1.0f);
// [shape] of scale * N(0, 1), by Box-Muller.
Tensor random_normal(Graph& g, const std::string& name, Shape shape, RandomStream rs, float scale = 1.0f);

// The host's Philox4x32-10 (the same bits as the kernels'): for references and tests.
std::array<uint32_t, 4> philox4x32_10(std::array<uint32_t, 4> counter, std::array<uint32_t, 2> key);

}  // namespace nova

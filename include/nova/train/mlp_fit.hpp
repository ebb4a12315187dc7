#pragma once
// Fits the NeRF MLP (positional encoding -> MLP) to a smooth function of 3D points: the
// end-to-end check that runtime, graph, ops and optimiser train together, used by
// `nova train-mlp`, the tests and the benchmark.
#include <array>
#include <functional>
#include <random>
#include <vector>

#include "nova/model/mlp.hpp"
#include "nova/runtime/runtime.hpp"

namespace nova {

struct MlpFitConfig {
  MlpConfig mlp;          // outputs must be 4
  int frequencies = 10;   // 3 -> 63 inputs, as the reference xyz encoding
  size_t batch = 1024;
  int steps = 300;
  float lr = 5e-4f;
  unsigned seed = 1;
  bool profile = false;
};

struct MlpFitResult {
  double initial_loss = 0;  // on a fixed held-out set of points, before training
  double final_loss = 0;    // the same set, after training
  double seconds = 0;       // training wall time
  double samples_per_second = 0;
  size_t parameters = 0;
  size_t arena_bytes = 0;       // planned activation memory
  size_t unplanned_bytes = 0;   // what one buffer per tensor would need
  std::string profile;          // per-op table when config.profile
};

// The target: four smooth functions of (x, y, z) in [-1, 1]^3, values in about [0, 1].
std::array<float, 4> smooth_target(float x, float y, float z);

// n points drawn uniformly in [-1, 1]^3 from rng (x, y, z in turn; n x 3 floats) and the
// first `outputs` (1-4) components of smooth_target at each (n x outputs floats).
void sample_smooth_function(std::mt19937& rng, size_t n, int outputs, std::vector<float>& points,
                            std::vector<float>& target);

using FitProgress = std::function<void(int step, float loss, double seconds)>;
MlpFitResult fit_smooth_function(Runtime& rt, const MlpFitConfig& config,
                                 const FitProgress& progress = {});

}  // namespace nova

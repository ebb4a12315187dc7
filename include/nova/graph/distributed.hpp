#pragma once
// Data-parallel training over processes (ranks), each with its own device. Every rank draws
// the same step (frame, augmentation, all R pixels) from the same generator and trains on its
// share of the rays, [rank R / N, (rank + 1) R / N), with the device randomness of exactly
// those rays (random.hpp slices); the gradients are summed through a GradientReducer and
// divided by N, so every rank's Adam makes the same update. The terms normalised by a statistic
// of the batch (depth standardisation, the free-space fit, the reference conventions' mask
// areas and counts) take it over every rank's rays through rank_sum ops in the step graph. nova_core knows no MPI: `nova train` implements the
// reducer with MPI when it is built with it.
#include <cstddef>
#include <vector>

namespace nova {

class GradientReducer {
 public:
  virtual ~GradientReducer() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  // values <- the sum over ranks of each rank's `values` (the same length on every rank), in
  // rank order, so every rank gets the same bits.
  virtual void sum(std::vector<float>& values) = 0;
};

// A rank's share of a step's rays.
struct RaySlice {
  size_t global_rays = 0;  // 0: no slicing (one process)
  size_t first_ray = 0;
  // The ranks, for the loss terms normalised by a statistic of the whole batch (rank_sum.hpp).
  GradientReducer* ranks = nullptr;
};

}  // namespace nova

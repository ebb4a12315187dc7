#pragma once
// nova-bench mlp's comparison of fused dense layers (dense: bias + activation in the GEMM's
// store where nova's own kernel runs the product) with the two ops they replace
// (linear + bias_act), timed alternately in one run.
#include <functional>
#include <string>

#include "nova/runtime/runtime.hpp"

namespace nova::bench {

struct FusedTimes {
  double fused = 0, two_ops = 0;  // seconds, medians
  double ratio() const { return fused > 0 ? two_ops / fused : 0; }  // > 1: fusion wins
};

// Medians of `repeats` timings of each, run alternately (fused, two ops, fused, ...) after one
// warm-up of each, so that a change in the machine's load hits both alike.
FusedTimes time_alternating(int repeats, const std::function<void()>& fused,
                            const std::function<void()>& two_ops);

// One w -> w ReLU layer at m rows: forward alone and forward + backward (the input's gradient
// included, as for a hidden layer), fused and as two ops. `config` gets the forward GEMM's
// configuration (what decides whether the fused op really fuses).
struct DenseLayerTimes {
  FusedTimes forward, step;
  std::string config;
};
DenseLayerTimes time_dense_layer(Runtime& rt, size_t m, size_t w, int repeats);

}  // namespace nova::bench

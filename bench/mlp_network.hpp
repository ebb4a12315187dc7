#pragma once
// The network nova-bench's MLP benchmarks run (bench_mlp.cpp, torch_compare.cpp): the MLP on
// constant inputs x [m, 63] = 0.1, with an MSE loss against 0.5 for training, else the output
// kept.
#include <memory>

#include "nova/graph/executor.hpp"
#include "nova/model/mlp.hpp"

namespace nova::bench {

constexpr size_t kMlpInputs = 63;  // the paper's positional encoding of xyz

struct MlpNetwork {
  Graph g;
  std::unique_ptr<Executor> ex;  // built on g, with its inputs set
};

std::unique_ptr<MlpNetwork> mlp_network(Runtime& rt, const MlpConfig& c, size_t rows, bool train,
                                        bool profile = false);

}  // namespace nova::bench

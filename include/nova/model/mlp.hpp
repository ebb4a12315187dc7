#pragma once
// The NeRF MLP, built from a configuration: `depth` dense layers of `width` with ReLU, the
// network input re-concatenated to the output of layer `skip` (0-based; the reference uses 4,
// so layer index 5 reads [input, h]), then an output layer. Several same-shaped networks share one graph by a batch
// dimension: every layer of the B networks is then one batched GEMM.
#include <string>
#include <vector>

#include "nova/graph/graph.hpp"
#include "nova/ops/linalg/dense.hpp"

namespace nova {

struct MlpConfig {
  int depth = 8;
  int width = 256;
  int skip = 4;  // 0-based layer whose output gets the input appended; < 0 for none
  int outputs = 4;
  Activation output_activation = Activation::Identity;
  int networks = 1;  // B: networks of this shape run as batched GEMMs
  // Layers as one op each (dense: bias + activation fused into the GEMM where nova's own
  // kernel runs it) or as linear + bias_act (the benchmark compares the two).
  bool fused_layers = true;
};

struct Mlp {
  Tensor output;                 // [rows, outputs] or [B, rows, outputs]
  std::vector<Tensor> weights;   // per layer
  std::vector<Tensor> biases;
  double flops_per_row = 0;      // forward multiply-adds x 2, per input row and network
};

// Builds the network on `input` ([rows, in] or [B, rows, in] when networks > 1). Weights are
// initialised as PyTorch's nn.Linear does: uniform in +-1/sqrt(fan_in).
Mlp build_mlp(Tensor input, const MlpConfig& config, const std::string& name = "mlp");

// One dense layer with its own parameters `name`.w / `name`.b, initialised as build_mlp's:
// x [rows, k] -> [rows, n], or [B, rows, k] -> [B, rows, n] for networks = B > 1.
Tensor dense_layer(Tensor x, int n, Activation act, const std::string& name, int networks = 1);

}  // namespace nova

#pragma once
// The dense-layer ops. Each builder adds one op to the graph of its inputs and returns its
// output. Shapes are row-major; the last dimension is the feature dimension.
// Several same-shaped networks are stacked in a leading batch dimension B: x [B, M, K],
// w [B, K, N], b [B, N].
#include "nova/graph/graph.hpp"

namespace nova {

enum class Activation { Identity, ReLU, Sigmoid, Softplus };
const char* activation_name(Activation a);

// y = x * w through the GEMM provider (CLBlast), one batched GEMM when B > 1.
// x [M, K] or [B, M, K]; w [K, N] or [B, K, N].
Tensor linear(Tensor x, Tensor w);

// y = act(h + b), the bias broadcast over rows; h [M, N] or [B, M, N], b [N] or [B, N].
Tensor bias_act(Tensor h, Tensor b, Activation act);

// A dense layer, y = act(x w + b): the values of bias_act(linear(x, w), b, act) as one op.
// Where the tuned GEMM for the shape is one of nova's own kernels, the bias and activation are
// applied as the product is stored (one pass over y instead of two); with CLBlast they stay a
// second pass. Saves x, w and y for backward (no pre-activation tensor).
Tensor dense(Tensor x, Tensor w, Tensor b, Activation act);

}  // namespace nova

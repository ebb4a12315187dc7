#pragma once
// The ops a graph is built from. Each builder adds one op to the graph of its inputs and
// returns its output. Shapes are row-major; the last dimension is the feature dimension.
// Several same-shaped networks are stacked in a leading batch dimension B: x [B, M, K],
// w [B, K, N], b [B, N].
#include <vector>

#include "nova/graph.hpp"

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

// Concatenation along the last dimension; all other dimensions must match.
Tensor concat(const std::vector<Tensor>& parts);

// NeRF positional encoding of the last dimension D: [p, sin(2^0 p), cos(2^0 p), ...,
// sin(2^(L-1) p), cos(2^(L-1) p)], each block D wide (no pi factor), D * (1 + 2L) outputs.
Tensor positional_encoding(Tensor p, int frequencies);

// Mean over all elements of (pred - target)^2: a scalar.
Tensor mse(Tensor pred, Tensor target);

// y = x; the backward passes x's gradient scaled per group of rows: dx[r * G + j] = dy[r * G + j]
// gate[gate_row, r] for x [R * G, C] and gate [rows, R] (data, no gradient). Deliberately not
// the derivative of the forward: a gate of 0 stops what flows through those rows, 1 is the
// identity. Joint training gates the static NeRF's samples with each ray's background mask.
Tensor gradient_gate(Tensor x, Tensor gate, size_t gate_row = 0);

// x [B, C] (data) -> [B, rows, C] ([rows, C] for B = 1): batch b's row in each of its rows.
// Spreads a per-group constant (an object's time) over its samples without a host upload.
Tensor repeat_rows(Tensor x, size_t rows);

// sum_i weights[i] * terms[i] over scalars.
Tensor weighted_sum(const std::vector<Tensor>& terms, const std::vector<float>& weights);

}  // namespace nova

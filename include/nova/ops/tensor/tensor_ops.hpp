#pragma once
// Ops that move rows and columns of tensors; shapes are row-major, the last dimension the
// feature dimension.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "nova/graph/graph.hpp"

namespace nova {

// Concatenation along the last dimension; all other dimensions must match.
Tensor concat(const std::vector<Tensor>& parts);

// y = x; the backward passes x's gradient scaled per group of rows: dx[r * G + j] = dy[r * G + j]
// gate[gate_row, r] for x [R * G, C] and gate [rows, R] (data, no gradient). Deliberately not
// the derivative of the forward: a gate of 0 stops what flows through those rows, 1 is the
// identity. Only columns [0, gated_cols) are gated; the others pass their gradient whole. Joint
// training gates the static NeRF's samples with each ray's background mask.
Tensor gradient_gate(Tensor x, Tensor gate, size_t gate_row = 0, size_t gated_cols = SIZE_MAX);

// x [B, C] (data) -> [B, rows, C] ([rows, C] for B = 1): batch b's row in each of its rows.
// Spreads a per-group constant (an object's time) over its samples without a host upload.
Tensor repeat_rows(Tensor x, size_t rows);

// y[..., c] = x[..., c] w[c] for weights [C] (data): every row's columns scaled alike.
// Differentiable in x.
Tensor scale_columns(Tensor x, Tensor weights);

// y + bound tanh(raw), elementwise, for y and raw of one shape: a position moved by a learned
// offset that stays within `bound` (> 0) of it. Differentiable in both.
Tensor bounded_offset(Tensor y, Tensor raw, float bound);

// x [B, M, 3] (or [M, 3]) in the coordinates of one box per batch, box [B, 6] (or [6]) rows
// (c, l): y = (x - c) exp(l) per axis, so the box c +- exp(-l) becomes [-1, 1]^3 and zeros
// are the identity. Differentiable in x; the box is a constant (no gradient).
Tensor box_coordinates(Tensor x, Tensor box);

}  // namespace nova

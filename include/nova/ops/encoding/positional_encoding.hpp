#pragma once
// The positional encoding of NeRF (the hash grid is hash_encoding.hpp).
#include "nova/graph/graph.hpp"

namespace nova {

// NeRF positional encoding of the last dimension D: [p, sin(2^0 p), cos(2^0 p), ...,
// sin(2^(L-1) p), cos(2^(L-1) p)], each block D wide (no pi factor), D * (1 + 2L) outputs.
Tensor positional_encoding(Tensor p, int frequencies);

}  // namespace nova

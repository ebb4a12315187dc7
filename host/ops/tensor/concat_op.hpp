#pragma once
// The column-block concatenation op, shared by concat (blocks of each row) and stack (whole
// tensors as blocks of one row: the parts are contiguous in the result).
#include <memory>
#include <string>
#include <vector>

#include "nova/graph/graph.hpp"

namespace nova {

// dst[r] = [part_0[r], part_1[r], ...] for `rows` rows, part i being widths[i] wide; the
// backward splits the gradient. `type` names the op in profiles.
std::unique_ptr<Op> make_column_concat(size_t rows, std::vector<size_t> widths, std::string type);

}  // namespace nova

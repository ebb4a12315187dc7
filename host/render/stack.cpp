// Stacking along the leading (NeRF) dimension: a static MLP's [M, C] output and a batched
// object MLP's [K, M, C] become one [1 + K, M, C] tensor for render_composite. The parts are
// contiguous blocks of the result, so stacking is a concatenation of one row whose blocks are
// the whole parts.
#include "ops/tensor/concat_op.hpp"
#include "nova/runtime/error.hpp"
#include "nova/render/render_composite.hpp"

namespace nova {

Tensor stack(const std::vector<Tensor>& parts) {
  if (parts.empty()) throw Error("stack of nothing", kExitInternal);
  const auto inner = [](const Shape& s) {
    if (s.rank() == 2) return s;
    if (s.rank() == 3) return Shape{s[1], s[2]};
    throw Error("stack: parts must be [M, C] or [B, M, C], got " + s.str(), kExitInternal);
  };
  const Shape first = inner(parts[0].shape());
  size_t batch = 0;
  std::vector<size_t> sizes;
  for (const Tensor& t : parts) {
    if (!(inner(t.shape()) == first) || t.graph != parts[0].graph)
      throw Error("stack: " + t.shape().str() + " does not fit " + first.str(), kExitInternal);
    batch += t.shape().rank() == 3 ? t.shape()[0] : 1;
    sizes.push_back(t.shape().numel());
  }
  Graph& g = *parts[0].graph;
  Tensor y = g.activation(parts[0].info().name + ".stack", Shape{batch, first[0], first[1]});
  g.add(make_column_concat(1, sizes, "stack"), parts, {y});
  return y;
}

}  // namespace nova

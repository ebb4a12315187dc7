#include "nova/mlp.hpp"

#include <cmath>

#include "nova/error.hpp"

namespace nova {

Mlp build_mlp(Tensor input, const MlpConfig& c, const std::string& name) {
  if (c.depth < 1 || c.width < 1 || c.outputs < 1 || c.networks < 1 || c.skip >= c.depth)
    throw Error("mlp '" + name + "': depth, width, outputs and networks must be positive and "
                "skip < depth",
                kExitUsage);
  const bool batched = c.networks > 1;
  if (input.shape().rank() != (batched ? 3u : 2u) ||
      (batched && input.shape()[0] != static_cast<size_t>(c.networks)))
    throw Error("mlp '" + name + "': input " + input.shape().str() + " does not fit " +
                    std::to_string(c.networks) + " network(s)",
                kExitInternal);
  Graph& g = *input.graph;
  const size_t in = input.shape().cols();
  const size_t nets = static_cast<size_t>(c.networks);
  const auto wshape = [&](size_t k, size_t n) {
    return batched ? Shape{nets, k, n} : Shape{k, n};
  };
  const auto bshape = [&](size_t n) { return batched ? Shape{nets, n} : Shape{n}; };

  Mlp mlp;
  Tensor h = input;
  const auto layer = [&](size_t k, size_t n, Activation act, const std::string& lname) {
    const float bound = 1.0f / std::sqrt(static_cast<float>(k));
    Tensor w = g.parameter(name + "." + lname + ".w", wshape(k, n), Init::uniform(bound));
    Tensor b = g.parameter(name + "." + lname + ".b", bshape(n), Init::uniform(bound));
    mlp.weights.push_back(w);
    mlp.biases.push_back(b);
    mlp.flops_per_row += 2.0 * static_cast<double>(k) * static_cast<double>(n);
    return dense(h, w, b, act);
  };
  size_t width_in = in;
  for (int i = 0; i < c.depth; ++i) {
    h = layer(width_in, c.width, Activation::ReLU, "l" + std::to_string(i));
    width_in = c.width;
    if (i == c.skip) {
      h = concat({input, h});
      width_in = in + c.width;
    }
  }
  mlp.output = layer(width_in, c.outputs, c.output_activation, "out");
  return mlp;
}

}  // namespace nova

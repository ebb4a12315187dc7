#include "nova/model/mlp.hpp"

#include <cmath>

#include "nova/ops/tensor/tensor_ops.hpp"
#include "nova/runtime/error.hpp"

namespace nova {
namespace {

struct Layer {
  Tensor w, b, y;
};

Layer make_layer(Tensor x, size_t n, Activation act, const std::string& name, size_t networks,
                 bool fused = true) {
  Graph& g = *x.graph;
  const size_t k = x.shape().cols();
  const bool batched = networks > 1;
  const float bound = 1.0f / std::sqrt(static_cast<float>(k));
  Layer l;
  l.w = g.parameter(name + ".w", batched ? Shape{networks, k, n} : Shape{k, n}, Init::uniform(bound));
  l.b = g.parameter(name + ".b", batched ? Shape{networks, n} : Shape{n}, Init::uniform(bound));
  l.y = fused ? dense(x, l.w, l.b, act) : bias_act(linear(x, l.w), l.b, act);
  return l;
}

}  // namespace

Tensor dense_layer(Tensor x, int n, Activation act, const std::string& name, int networks) {
  if (n < 1 || networks < 1) throw Error("layer '" + name + "': sizes must be positive", kExitUsage);
  return make_layer(x, static_cast<size_t>(n), act, name, static_cast<size_t>(networks)).y;
}

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
  const size_t in = input.shape().cols();
  const size_t nets = static_cast<size_t>(c.networks);

  Mlp mlp;
  Tensor h = input;
  const auto layer = [&](size_t k, size_t n, Activation act, const std::string& lname) {
    Layer l = make_layer(h, n, act, name + "." + lname, nets, c.fused_layers);
    mlp.weights.push_back(l.w);
    mlp.biases.push_back(l.b);
    mlp.flops_per_row += 2.0 * static_cast<double>(k) * static_cast<double>(n);
    return l.y;
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

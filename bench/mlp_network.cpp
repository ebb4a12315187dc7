#include "mlp_network.hpp"

#include "nova/loss/terms.hpp"

namespace nova::bench {

std::unique_ptr<MlpNetwork> mlp_network(Runtime& rt, const MlpConfig& c, size_t rows, bool train,
                                        bool profile) {
  auto n = std::make_unique<MlpNetwork>();
  Tensor x = n->g.input("x", Shape{rows, kMlpInputs});
  Tensor target = n->g.input("target", Shape{rows, 4});
  Tensor y = build_mlp(x, c).output;
  if (train)
    n->g.set_loss(mse(y, target));
  else
    n->g.keep(y);
  ExecutorOptions eo;
  eo.profile = profile;
  n->ex = std::make_unique<Executor>(rt, n->g, eo);
  n->ex->set(x, std::vector<float>(rows * kMlpInputs, 0.1f));
  n->ex->set(target, std::vector<float>(rows * 4, 0.5f));
  return n;
}

}  // namespace nova::bench

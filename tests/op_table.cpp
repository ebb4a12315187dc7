#include "op_table.hpp"

#include <cmath>

#include "nova/runtime/error.hpp"
#include "nova/loss/terms.hpp"

namespace nova::test {

const std::vector<OpEntry>& op_table() {
  static const std::vector<OpEntry> table = [] {
    std::vector<OpEntry> t;
    register_core_ops(t);
    register_loss_ops(t);
    register_ray_loss_ops(t);
    register_render_ops(t);
    register_grid_ops(t);
    register_motion_ops(t);
    register_rank_ops(t);
    return t;
  }();
  return table;
}

ShapeSetup::ShapeSetup(const OpEntry& entry, const OpShape& shape, const Runtime& rt) : entry_(entry) {
  if (!entry.prepare) return;
  skipped_ = entry.prepare(shape, rt);
  prepared_ = skipped_.empty();
}

ShapeSetup::~ShapeSetup() {
  if (prepared_ && entry_.restore) entry_.restore();
}

std::unique_ptr<BuiltEntry> build_entry(const OpEntry& e, const OpShape& s) {
  auto b = std::make_unique<BuiltEntry>();
  b->op = e.build(b->g, s);
  for (const Tensor& t : b->op.outputs) b->g.keep(t);
  bool any_grad = false;
  for (const Tensor& t : b->op.inputs) any_grad = any_grad || t.info().requires_grad;
  if (b->op.loss.valid()) {
    b->g.set_loss(b->op.loss);
  } else if (any_grad) {
    std::vector<Tensor> terms;
    for (size_t k = 0; k < b->op.outputs.size(); ++k) {
      const Tensor& out = b->op.outputs[k];
      b->targets.push_back(b->g.input("target." + std::to_string(k), out.shape()));
      terms.push_back(mse(out, b->targets.back()));
    }
    b->g.set_loss(terms.size() == 1 ? terms[0]
                                    : weighted_sum(terms, std::vector<float>(terms.size(), 1.0f)));
  }
  return b;
}

std::vector<std::vector<float>> set_entry_inputs(Executor& ex, const BuiltEntry& b,
                                                 const std::vector<std::vector<float>>& values) {
  if (values.size() != b.op.inputs.size())
    throw Error("op table: " + std::to_string(values.size()) + " input values for " +
                std::to_string(b.op.inputs.size()) + " inputs", kExitInternal);
  for (size_t i = 0; i < values.size(); ++i) ex.set(b.op.inputs[i], values[i]);
  std::vector<std::vector<float>> targets;
  for (size_t k = 0; k < b.targets.size(); ++k) {
    targets.push_back(random_floats(b.targets[k].shape().numel(), -1.0f, 1.0f, 7 + unsigned(k)));
    ex.set(b.targets[k], targets.back());
  }
  return targets;
}

std::vector<double> mse_upstream(const std::vector<float>& out, const std::vector<float>& target) {
  std::vector<double> g(out.size());
  for (size_t i = 0; i < out.size(); ++i) g[i] = 2.0 * (double(out[i]) - target[i]) / double(out.size());
  return g;
}

double max_abs(const std::vector<double>& v) {
  double m = 1e-30;
  for (double x : v) m = std::max(m, std::fabs(x));
  return m;
}

Expected grad_expected(std::vector<double> want) {
  const double scale = max_abs(want);
  return {std::move(want), {1e-6 * scale, 1e-5}};
}

}  // namespace nova::test

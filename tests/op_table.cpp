#include "op_table.hpp"

#include <cmath>

namespace nova::test {

const std::vector<OpEntry>& op_table() {
  static const std::vector<OpEntry> table = [] {
    std::vector<OpEntry> t;
    register_core_ops(t);
    register_loss_ops(t);
    register_ray_loss_ops(t);
    register_render_ops(t);
    register_grid_ops(t);
    register_rank_ops(t);
    return t;
  }();
  return table;
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

// The op table's batch statistics over ranks (rank_sum.hpp, kernels/rank_moments.cl): rank_sum,
// the depth loss from the whole batch's moments and the free-space fit from them. One process
// has one rank, so the ranks are two with identical rays (twin_ranks_reducer.hpp): a sum over
// ranks is twice this rank's value. Then rank_sum is y = 2 x with the adjoint dx = 2 dy; the
// means and variances of duplicated rays are those of one copy, so the losses equal one
// process's losses of the same rays; and the gradient a rank gets (2 x the partial derivative
// in its own copy, the adjoint being a sum over both ranks) is one process's gradient (the
// partial in one copy is half the derivative in both). The entries check this against the
// single-process float64 references and the central differences of the device forward.
#include <cmath>

#include "free_space_reference.hpp"
#include "loss_reference.hpp"
#include "nova/loss/terms.hpp"
#include "nova/ops/tensor/rank_sum.hpp"
#include "op_table.hpp"
#include "twin_ranks_reducer.hpp"

namespace nova::test {

// Ops hold a reference to their reducer: one for every graph of the table.
GradientReducer& twin_ranks() {
  static TwinRanksReducer ranks;
  return ranks;
}

namespace {

// rank_sum: the forward doubles exactly (a float sum of two equal values), so tolerance 0;
// the adjoint is 2 x the device's upstream gradient (harness default tolerance). Central
// differences (harness default) at 7 values.
OpEntry rank_sum_entry() {
  OpEntry e;
  e.name = "rank_sum";
  e.shapes = {{{kOddRows}, 0, "1009 values"}, {{7}, 0, "7 values"}, {{1}, 0, "1 value"}};
  e.build = [](Graph& g, const OpShape& s) {
    Tensor x = g.input("x", Shape{s.dims[0]}, true);
    return OpGraph{{x}, {rank_sum(x, twin_ranks())}, {}};
  };
  e.values = [](const OpShape& s) { return std::vector<std::vector<float>>{random_floats(s.dims[0], -2, 2, 191)}; };
  e.reference = [](const OpCase& c) {
    std::vector<double> y(c.values[0].size());
    for (size_t i = 0; i < y.size(); ++i) y[i] = 2.0 * c.values[0][i];
    return std::vector<Expected>{{y, {0, 0}}};
  };
  e.gradient = [](const OpCase& c) {
    std::vector<double> dx = c.upstream[0];
    for (double& v : dx) v *= 2.0;
    return std::vector<Expected>{grad_expected(dx)};
  };
  e.fd = GradCheckOptions{};
  e.flops = [](const OpShape& s) { return double(s.dims[0]) * 2; };  // one add each way
  return e;
}

// depth_loss through the moments (moment_sums twice, rank_sum twice, depth_loss_from_moments,
// and their backward kernels) against the single-process float64 depth loss of the same rays.
// Every fifth ray invalid; 2 rays leave one valid ray: no statistic, loss and gradient 0.
OpEntry depth_from_moments_entry() {
  OpEntry e = depth_loss_entry(&twin_ranks());
  e.shapes = {{{kOddRows}, 0, "1009 rays"}, {{57}, 0, "57 rays"}, {{7}, 0, "7 rays"}, {{2}, 0, "2 rays, 1 valid"}};
  return e;
}

// free_space_loss with the fit from the whole batch's moments (moment_sums with the masks'
// weights, free_space_fit_from_moments): 2 NeRFs x rays x 3 samples, the single-process
// entry's case (free_space_table_case), against its float64 loss (rtol 1e-4) and the central
// differences in sigma (rtol 1e-3, atol 1e-5 of the gradient's scale) as that entry. The
// depth also feeds an mse, so it takes a gradient: the fit's moments are constants and add
// none, leaving the mse's 2 depth / R (float32 of two roundings: rtol 1e-6). The check is
// op_table_checks.cpp's.
OpEntry free_space_over_ranks_entry() {
  OpEntry e;
  e.name = "free_space_loss_over_ranks";
  e.shapes = {{{2, kOddRows, 3}, 0, "2 NeRFs x 1009 rays x 3"}, {{2, 9, 3}, 0, "2 NeRFs x 9 rays x 3"}};
  e.build = [](Graph& g, const OpShape& s) { return free_space_graph(g, s, &twin_ranks()); };
  e.values = free_space_values;
  e.flops = [](const OpShape& s) { return double(s.dims[0] * s.dims[1] * s.dims[2]) * 40 + double(s.dims[1]) * 16; };
  return e;
}

}  // namespace

void register_rank_ops(std::vector<OpEntry>& t) {
  t.push_back(rank_sum_entry());
  t.push_back(depth_from_moments_entry());
  t.push_back(free_space_over_ranks_entry());
}

}  // namespace nova::test

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
#include "nova/losses.hpp"
#include "nova/rank_sum.hpp"
#include "op_table.hpp"
#include "twin_ranks_reducer.hpp"

namespace nova::test {

namespace {

// Ops hold a reference to their reducer: one for every graph of the table.
GradientReducer& twin_ranks() {
  static TwinRanksReducer ranks;
  return ranks;
}

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
  OpEntry e;
  e.name = "depth_loss_over_ranks";
  e.shapes = {{{kOddRows}, 0, "1009 rays"}, {{57}, 0, "57 rays"}, {{7}, 0, "7 rays"},
              {{2}, 0, "2 rays, 1 valid"}};
  e.build = [](Graph& g, const OpShape& s) {
    const Shape sh{s.dims[0]};
    Tensor p = g.input("depth", sh, true), t = g.input("target", sh), w = g.input("valid", sh);
    Tensor l = depth_loss(p, t, w, &twin_ranks());
    return OpGraph{{p, t, w}, {l}, l};
  };
  e.values = [](const OpShape& s) {
    std::vector<float> w(s.dims[0], 1.0f);
    for (size_t i = 0; i < w.size(); i += 5) w[i] = 0.0f;
    return std::vector<std::vector<float>>{random_floats(s.dims[0], 0.0f, 1.0f, 181),
                                           random_floats(s.dims[0], -2.0f, 3.0f, 182), w};
  };
  // Float32 sums of the rays' moments in one work-item (a relative error of a few 1e-6 at
  // 1009 rays), and a loss near 2 for uncorrelated depths (no cancellation): rtol 1e-4 as the
  // single kernel's entry.
  e.reference = [](const OpCase& c) {
    return std::vector<Expected>{{{ref_depth_loss(to_double(c.values[0]), c.values[1], c.values[2])}, {0, 1e-4}}};
  };
  // Central differences of the float64 loss (h = 1e-6, exact to ~1e-9); the standardisation's
  // cancellations: rtol 1e-3 and atol 1e-4 of the gradient's scale (the single kernel's entry).
  e.gradient = [](const OpCase& c) {
    std::vector<double> d = to_double(c.values[0]), fd(d.size());
    for (size_t r = 0; r < d.size(); ++r) {
      const double x0 = d[r], h = 1e-6;
      d[r] = x0 + h;
      const double lp = ref_depth_loss(d, c.values[1], c.values[2]);
      d[r] = x0 - h;
      const double lm = ref_depth_loss(d, c.values[1], c.values[2]);
      d[r] = x0;
      fd[r] = (lp - lm) / (2 * h);
    }
    return std::vector<Expected>{{fd, {1e-4 * max_abs(fd), 1e-3}}, {}, {}};
  };
  e.fd = GradCheckOptions{};
  // Two passes of ~6 operations a ray forward and ~10 backward; the scalar kernels are O(1).
  e.flops = [](const OpShape& s) { return double(s.dims[0]) * 32; };
  return e;
}

// free_space_loss with the fit from the whole batch's moments (moment_sums with the masks'
// weights, free_space_fit_from_moments): 2 NeRFs x rays x 3 samples, the single-process
// entry's case (free_space_table_case), against its float64 loss (rtol 1e-4) and the central
// differences in sigma (rtol 1e-3, atol 1e-5 of the gradient's scale) as that entry. The
// depth also feeds an mse, so the moments' backward runs: the fit adds no gradient, leaving
// the mse's 2 depth / R (float32 of two roundings: rtol 1e-6).
FreeSpaceCase free_space_case(const OpShape& s) { return free_space_table_case(s.dims[0], s.dims[1], s.dims[2]); }

OpEntry free_space_over_ranks_entry() {
  OpEntry e;
  e.name = "free_space_loss_over_ranks";
  e.shapes = {{{2, kOddRows, 3}, 0, "2 NeRFs x 1009 rays x 3"}, {{2, 9, 3}, 0, "2 NeRFs x 9 rays x 3"}};
  e.build = [](Graph& g, const OpShape& s) {
    const size_t N = s.dims[0], R = s.dims[1], S = s.dims[2];
    Tensor raw = g.input("raw", Shape{N, R * S, 5}, true), delta = g.input("delta", Shape{N, R, S});
    Tensor z = g.input("z", Shape{R, S}), depth = g.input("depth", Shape{R}), target = g.input("target", Shape{R});
    Tensor valid = g.input("valid", Shape{R}), masks = g.input("masks", Shape{N, R});
    Tensor l = free_space_loss(raw, delta, z, depth, target, valid, masks, {}, 0.05f, 1, 0.5f, &twin_ranks());
    return OpGraph{{raw, delta, z, depth, target, valid, masks}, {l}, l};
  };
  e.values = [](const OpShape& s) {
    const FreeSpaceCase f = free_space_case(s);
    return std::vector<std::vector<float>>{f.raw, f.delta, f.z, f.depth, f.target, f.valid, f.masks};
  };
  e.check = [](const OpShape& s) {
    const FreeSpaceCase f = free_space_case(s);
    const FreeSpaceRun run = run_free_space(f, runtime(), true, &twin_ranks());
    expect_close({run.loss}, {free_space_reference(f, f.raw)}, 0, 1e-4, "free_space_loss over ranks");
    const std::vector<double> fd = free_space_sigma_fd(f, 1e-3f);
    expect_close(run.d_raw, fd, 1e-5 * max_abs(fd), 1e-3, "d free_space_loss over ranks / d raw");
    std::vector<double> d_depth(f.R);
    for (size_t r = 0; r < f.R; ++r) d_depth[r] = 2.0 * f.depth[r] / double(f.R);
    expect_close(run.d_depth, d_depth, 0, 1e-6, "d free_space_loss over ranks / d depth (the mse's alone)");
  };
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

#pragma once
// The reference code's ratio losses (masked_mse_area, alpha_loss_outside, order_loss: each
// sum_g num_g / (den_g + eps) / c, kernels/reference_terms.cl) in two steps, for data-parallel
// training: a rank's sums, which rank_sum makes the whole batch's, then the loss from them.
#include "nova/graph/graph.hpp"

namespace nova::detail {

// sums [2 groups]: (num_g, den_g) per group, of the rays given; c and eps of the loss.
struct GroupSums {
  Tensor sums;
  size_t groups = 0;
  float c = 1.0f, eps = 0.0f;
};

// The sums of each loss (arguments as in losses.hpp); their gradient flows to the inputs the
// loss differentiates (the numerators'; the denominators depend on data alone).
GroupSums masked_mse_area_sums(Tensor pred, Tensor target, Tensor mask);
GroupSums alpha_loss_outside_sums(Tensor raw, Tensor delta, Tensor masks, Tensor noise, bool blend_sigmoid);
GroupSums order_loss_sums(Tensor nerf_depth, Tensor masks);

// sum_g num_g / (den_g + eps) / c (0 for a group with den_g + eps <= 0), differentiable in
// both sums.
Tensor group_ratio(const GroupSums& s);

}  // namespace nova::detail

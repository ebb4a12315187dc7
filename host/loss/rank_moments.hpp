#pragma once
// The moments of a batch split over ranks (kernels/rank_moments.cl), for the losses that
// normalise by a statistic of the batch (depth_loss.cpp, free_space_loss.cpp).
#include "nova/graph/distributed.hpp"
#include "nova/graph/graph.hpp"

namespace nova::detail {

// The whole batch's sums with w = valid (times mask's first R values where mask is valid):
// first = (sum w, sum w p, sum w t), second = (sum w dp^2, sum w dt^2, sum w dp dt) about
// first's means. p takes a gradient through both unless `constant` (the sums are then data,
// with no backward); t, valid and mask are data.
struct BatchMoments {
  Tensor first, second;
};
BatchMoments batch_moments(Tensor p, Tensor t, Tensor valid, Tensor mask, GradientReducer& ranks,
                           bool constant = false);

// The depth loss (depth_loss.cl's definition) of the whole batch, a scalar of its moments.
Tensor depth_loss_from_moments(const BatchMoments& m);

}  // namespace nova::detail

#pragma once
// The sum over ranks as a graph op (data-parallel training, distributed.hpp): a small tensor
// that depends on a rank's own rays (a batch statistic's partial sums) becomes the whole
// batch's, so a loss normalised by a statistic of the batch is the same on every rank as in
// one process.
#include "nova/graph/distributed.hpp"
#include "nova/graph/graph.hpp"

namespace nova {

// y = the sum over ranks of each rank's x, in rank order (GradientReducer::sum): the same bits
// on every rank. Every rank's loss reads y, so the adjoint is the sum over ranks too:
// dx = the sum over ranks of each rank's dy; the trainer's mean over ranks of the gradients
// then gives the gradient of the mean over ranks of the losses. Every rank must build the same
// graph (each op is a collective, forward and backward). A small tensor (it crosses the bus
// each way): a few floats.
Tensor rank_sum(Tensor x, GradientReducer& ranks);

}  // namespace nova

#pragma once
// The loss terms as graph ops; objective.hpp weighs them into the training loss.
#include <vector>

#include "nova/graph/distributed.hpp"
#include "nova/graph/graph.hpp"
#include "nova/render/render_composite.hpp"

namespace nova {

// Mean over all elements of (pred - target)^2: a scalar.
Tensor mse(Tensor pred, Tensor target);

// sum_i weights[i] * terms[i] over scalars.
Tensor weighted_sum(const std::vector<Tensor>& terms, const std::vector<float>& weights);

// Mean over all G*R*K elements of mask * (pred - target)^2.
// pred [G, R, K] or [R, K]; target [R, K] (shared by the G groups); mask [G, R] or [R].
// target and mask are data (no gradient).
Tensor masked_mse(Tensor pred, Tensor target, Tensor mask);

// Blending loss: mean over the M samples of |sum_n blend_n - 1|, raw [N, M, C] (kRawBlend
// channel; sigmoid applied here when blend_sigmoid, as render_composite does).
Tensor blending_loss(Tensor raw, bool blend_sigmoid = true);

// Alpha loss: alpha and blend of each object NeRF (n >= 1) pushed to 0 on rays outside its
// mask: sum over n >= 1, rays r, samples i of (1 - mask_n(r)) (alpha_n,i + blend_n,i), divided
// by K*R*S. An L1 penalty (both terms are >= 0), which drives them to exactly 0.
// raw [N, R*S, C], delta [R, S] or [N, R, S] and noise (optional) as render_composite;
// masks [N, R] as NovelViewTargets. The static NeRF (n = 0) is exempt: the background
// exists behind the objects too. Needs N >= 2.
Tensor alpha_loss(Tensor raw, Tensor delta, Tensor masks, Tensor noise = {},
                  bool blend_sigmoid = true);

// Depth up to scale and shift (kernels/depth_loss.cl): depth and target standardised over the
// rays with valid = 1, then their mean squared difference (2 (1 - correlation)). depth [R]
// (render_composite's), target [R] affine in depth with a positive slope (minus the
// disparity in NDC), valid [R] in {0, 1}; 0 when fewer than 2 rays are valid. As
// DynamicNeRF's depth term, it resolves the depth of objects seen from one camera per time.
// With `ranks` of more than one rank (data-parallel training, rank_sum.hpp) the rays are this
// rank's share and the statistics, hence the loss, are the whole batch's: every rank's value is
// the loss one process gets on all the rays (to float rounding: the sums run in another order).
Tensor depth_loss(Tensor depth, Tensor target, Tensor valid, GradientReducer* ranks = nullptr);

// Sparsity loss: sum over object NeRFs n >= 1, rays r, samples i of mask_n(r) alpha_n,i,
// divided by K*R*S (arguments as alpha_loss). For a given opacity 1 - prod(1 - alpha_i) the
// sum of alphas is smallest when one sample holds it all, so this L1 favours one compact
// surface per ray: an object seen from a single camera per time cannot smear its density
// along that camera's rays, which shows as streaks from any other camera.
Tensor sparsity_loss(Tensor raw, Tensor delta, Tensor masks, Tensor noise = {});

// Distortion loss (mip-NeRF 360), each NeRF with its own transmittance: the mean over NeRFs n
// and rays r of mask_n(r) sum_{i,j} w_i w_j |u_i - u_j|, w = T alpha its sample weights and u
// the sample depths z scaled to [0, 1] along the ray (kernels/distortion_loss.cl). 0 for one
// opaque sample, larger the more the weight is spread: it removes low-density haze and the
// streaks an object seen from one camera per time leaves along that camera's rays. raw
// [N, R*S, C] or [R*S, C], delta as render_composite, z [R, S], masks [N, R] (or Tensor{}:
// every ray), noise [N, R*S] (or Tensor{}). NeRFs below `first_nerf` take no part (the mean
// is over the others).
Tensor distortion_loss(Tensor raw, Tensor delta, Tensor z, Tensor masks = {}, Tensor noise = {},
                       size_t first_nerf = 0);

// Free-space loss (kernels/free_space_loss.cl): the weight each NeRF n >= first_nerf puts more than
// `margin` in front of the depth the disparity gives, on the rays of its mask, weighted by the
// distance: mean over NeRFs n and rays r of valid_r mask_n(r) sum_i w_i max(0, z*_r - margin
// - z_i), w = T alpha its own sample weights. The target z*_r = a + b target_r, (a, b) the
// least-squares fit of depth on target over the valid background rays (masks row 0), where
// the pretrained static NeRF's depth can be trusted: the disparity in the rendered depth's
// units (a constant: depth gets no gradient). It empties the space in front of an object seen
// from one camera per time, which the depth loss on the expected depth misses. With
// `behind` > 0 each sample also costs behind * max(0, z_i - z*_r - margin): weight pushed back
// along the rays, which the one camera that sees an object at a time cannot tell from the
// surface, is pulled to the disparity's depth too. raw, delta, z, masks, noise as
// distortion_loss; depth, target, valid [R] as depth_loss. With `ranks` of more than one rank
// the fit is the whole batch's, as depth_loss's statistics (the mean over (NeRF, ray) pairs
// needs nothing more: each rank has the same share of them). With `fitted` false the target
// is the surface itself in the rendered depth's units (z*_r = target_r, no fit; depth unused).
Tensor free_space_loss(Tensor raw, Tensor delta, Tensor z, Tensor depth, Tensor target,
                       Tensor valid, Tensor masks, Tensor noise = {}, float margin = 0.05f,
                       size_t first_nerf = 1, float behind = 0.0f, GradientReducer* ranks = nullptr,
                       bool fitted = true);

// Per-NeRF mask loss of the reference code: sum over NeRFs n of the mean over rays r of
// |mask_n(r) - target_n(r)|. mask [N, R] (render_composite's), target [N, R] (data).
Tensor mask_l1_loss(Tensor mask, Tensor target);

// Per-NeRF masked RGB loss of the reference code: sum over groups g of
// sum_{r,k} mask_g(r) (pred - target)^2 / (sum_r mask_g(r) + 1e-8) / K: each NeRF's squared
// error over its mask's area. pred [G, R, K]; target [G, R, K] (each group its own target)
// or [R, K] (shared); mask [G, R]. target and mask are data.
// The ratio losses of the reference code (masked_mse_area, alpha_loss_outside, order_loss) take
// `ranks` as depth_loss: with more than one rank the rays are this rank's share, and the
// numerators and the mask areas and counts they divide by are the whole batch's (summed over
// ranks by rank_sum), so every rank's value is one process's loss on all the rays.
Tensor masked_mse_area(Tensor pred, Tensor target, Tensor mask, GradientReducer* ranks = nullptr);

// Alpha loss of the reference code: for each object NeRF n >= 1, over the rays whose mask
// is not exactly 1 (and all their samples), the mean of blend_n plus the mean of alpha_n;
// summed over the objects (an object with no such ray adds 0). Arguments as alpha_loss.
Tensor alpha_loss_outside(Tensor raw, Tensor delta, Tensor masks, Tensor noise = {},
                          bool blend_sigmoid = true, GradientReducer* ranks = nullptr);

// Order loss of the reference code: the object NeRFs' depth on background rays is the
// static NeRF's. nerf_depth [N, R] (render_composite's, each NeRF alone), masks [N, R] (row
// 0 the background, data): sum over n >= 1 and rays r of masks_0(r) |depth_n(r) - depth_0(r)|,
// divided by (sum_r masks_0(r) + 1e-8) and by R (the reference's img2mae divides by the last
// dimension, which for [K, R] depth maps is R; split over ranks, the whole batch's R). Both
// depths get a gradient. Needs N >= 2.
Tensor order_loss(Tensor nerf_depth, Tensor masks, GradientReducer* ranks = nullptr);

}  // namespace nova

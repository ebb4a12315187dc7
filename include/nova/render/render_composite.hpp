#pragma once
// Multi-NeRF compositing through per-sample blending factors (NOVA): 1 static + K object
// NeRFs rendered along the same samples with one shared transmittance. The formulas are in
// kernels/render.cl; this header is the graph-level interface.
//
// The trainer chains: samples (rays.hpp) -> positional_encoding -> MLP -> stack (when the
// static and object NeRFs are separate MLPs) -> render_composite -> losses (losses.hpp).
#include <string>
#include <vector>

#include "nova/graph/graph.hpp"

namespace nova {

// Raw per-sample field outputs of one NeRF, row layout [rgb(3), sigma, blend, ...]: the
// channels a NeRF MLP emits with an Identity output activation. Further channels (scene flow
// and the like) may follow; the renderer ignores them and gives them a zero gradient.
constexpr int kRawRgb = 0, kRawSigma = 3, kRawBlend = 4, kRawChannels = 5;

struct RenderOptions {
  // Activations applied inside the renderer. With the defaults the renderer takes the raw MLP
  // output: rgb = sigmoid(raw), blend = sigmoid(raw), sigma = ReLU(raw + noise), as the
  // reference code. Set to false when the input is already activated (in [0, 1]).
  bool rgb_sigmoid = true;
  bool blend_sigmoid = true;
  // Inference only: the static blend is set to 0 wherever an object blend exceeds 0.5.
  bool hard_blend = false;
  // b_n = blend_n / (sum_m blend_m + blend_eps): nova's 1e-6 by default, the reference code's
  // 1e-8 under its conventions (LossConventions in novel_view_loss.hpp).
  float blend_eps = 1e-6f;
  // alpha_full_i in mask, depth and acc: 1 - prod_n (1 - alpha_n b_n) (false, the union of
  // the NeRFs' opacities) or sum_n alpha_n b_n (true, the reference code's weights_full).
  bool alpha_full_sum = false;
  // Plain NeRF compositing, no blending (b_n = 1, the blend channel gets no gradient): the
  // reference code's pretraining of the static NeRF alone (N = 1).
  bool no_blend = false;
  // Also render nerf_depth (each NeRF alone, as nerf_rgb): the order loss reads it.
  bool nerf_depth = false;
};

struct RenderOutputs {
  Tensor rgb;       // [R, 3]     composite colour
  Tensor nerf_rgb;  // [N, R, 3]  each NeRF alone, with its own transmittance, no blending
  Tensor mask;      // [N, R]     M_n = sum_i T_i alpha_full_i b_n,i
  Tensor depth;     // [R]        sum_i T_i alpha_full_i z_i
  Tensor acc;       // [R]        sum_i T_i alpha_full_i (= sum_n M_n)
  Tensor nerf_depth;  // [N, R]   sum_i T^n_i alpha_n,i z_i, each NeRF alone (only with
                      //          RenderOptions::nerf_depth; invalid otherwise)
};

// Renders N = raw.shape[0] NeRFs (1 <= N <= 16; NeRF 0 is the static one).
//   raw    [N, R*S, C] (C >= 5) or [R*S, C] for N = 1: see kRaw*; differentiable.
//   delta  [R, S] (shared) or [N, R, S] (per NeRF, each with its own |d|): sample spacing,
//          already multiplied by the ray direction's norm, 1e10 |d| for the last sample.
//   z      [R, S]: sample depths for the expected depth.
//   noise  optional [N, R*S] (or [N, R, S]), added to sigma before the ReLU while training
//          (the reference draws it from N(0, 1)); pass an empty Tensor{} at inference.
// delta, z and noise are data: they must not require a gradient.
RenderOutputs render_composite(Tensor raw, Tensor delta, Tensor z, Tensor noise = {},
                               const RenderOptions& options = {});

// The build options of kernels/render.cl for `nerfs` NeRFs: one program per NeRF count and
// option set. Exposed so that a warm-up can compile exactly what the op will use.
std::string render_program_options(size_t nerfs, const RenderOptions& options = {});

// Stacks tensors along a new (or existing) leading NeRF dimension: parts [M, C] or
// [B_j, M, C] give [sum B_j, M, C]. Lets a static MLP [M, C] and a batched object MLP
// [K, M, C] feed one render_composite. Differentiable.
Tensor stack(const std::vector<Tensor>& parts);

}  // namespace nova

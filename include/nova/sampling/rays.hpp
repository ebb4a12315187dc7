#pragma once
// Rays and stratified samples as graph ops (kernels/sampling.cl). One pixel batch gives one
// ray per NeRF, each from that NeRF's own camera (an object camera may be moved for novel-view
// augmentation). Forward only: the outputs are data for the MLPs and need no gradient.
//
// Typical chain for 1 static + K object NeRFs:
//   Rays rays = generate_rays(pixels, cameras, {.ndc = true});
//   Samples s = stratified_samples(rays, jitter, {.samples = 64, .groups = {1, K}});
//   s.positions[0] [R*S, 3] -> positional_encoding -> static MLP      -> raw [R*S, 5]
//   s.positions[1] [K, R*S, 3] (+ time) -> ... -> batched object MLP    -> raw [K, R*S, 5]
//   render_composite(stack({static, objects}), s.delta, s.z, noise)
#include <vector>

#include "nova/sampling/camera.hpp"
#include "nova/graph/graph.hpp"

namespace nova {

// Per-NeRF camera row of the `cameras` input: fx, fy, cx, cy, c2w (3x4 row-major).
constexpr int kCameraFloats = 16;
// The [N, 16] values for `cameras`, one row per NeRF (NeRF 0 = static).
std::vector<float> camera_rows(const std::vector<Camera>& cameras);

struct RayOptions {
  // Forward-facing (LLFF) scenes: rays in normalised device coordinates with the near plane
  // at `ndc_near` (the reference uses 1); samples then run over t in [0, 1]. Otherwise
  // (OpenGL / Blender scenes) rays stay metric and samples run over [near, far].
  bool ndc = false;
  float ndc_near = 1.0f;
};

struct Rays {
  Tensor origins;     // [N, R, 3] world (or NDC)
  Tensor directions;  // [N, R, 3] world (or NDC), not normalised: |d| scales the spacing
  Tensor viewdirs;    // [N, R, 3] unit world directions, taken before any NDC mapping
};

// pixels [R, 2] (column i, row j, in pixels; the frame chooses the cameras), cameras [N, 16]
// (camera_rows; an input set every step so augmented object cameras can change).
Rays generate_rays(Tensor pixels, Tensor cameras, const RayOptions& options = {});

struct SampleOptions {
  int samples = 64;
  float near = 0.0f, far = 1.0f;  // NDC: 0 and 1; metric: the scene bounds
  // How NeRFs are grouped into the MLP batches: the counts must sum to N. Each group gets its
  // own positions / viewdirs tensor, [R*S, 3] for a group of 1 and [B, R*S, 3] for B > 1.
  // Empty: one group of all N NeRFs.
  std::vector<int> groups;
};

struct Samples {
  std::vector<Tensor> positions;  // per group: [R*S, 3] or [B, R*S, 3], o + z d
  std::vector<Tensor> viewdirs;   // per group, same shape: the ray's unit view direction
  Tensor z;                       // [R, S] sample depth (NDC t or metric)
  Tensor delta;                   // [N, R, S] (z_{i+1} - z_i) |d_n|, last 1e10 |d_n|
};

// Stratified samples along `rays`. jitter: [R, S] uniform in [0, 1) while training (each
// sample uniform within its stratum, as the reference's perturb = 1), or an empty Tensor{}
// at inference (evenly spaced samples). warp: [W, 2] knots (sample_warp.hpp), the same for
// every ray, that move the stratified depths (as fractions of [near, far]) to where more
// samples are wanted; an empty Tensor{} leaves them evenly spread.
Samples stratified_samples(const Rays& rays, Tensor jitter, const SampleOptions& options = {},
                           Tensor warp = {});

// Composition: the positions [M, 3] of one render's samples as seen by B placed object
// instances. transforms [B, 12]: per instance the world-to-object map (the inverse of its
// placement, compose_spec.hpp), row-major 3x4. For NDC rays the map is applied in world
// coordinates (NDC -> world -> map -> NDC) with the NDC constants of the rays:
// ax = -fx / cx, ay = -fy / cy and the near plane. Returns [B, M, 3] ([M, 3] for B = 1),
// the layout of a batched object MLP's input. Forward only (data).
struct InstanceOptions {
  bool ndc = false;
  float ax = -1.0f, ay = -1.0f, ndc_near = 1.0f;
};
Tensor instance_points(Tensor positions, Tensor transforms, const InstanceOptions& options = {});

}  // namespace nova

#pragma once
// What one training step trains on: a frame, the pixels drawn from it (or from a view of it
// with the objects turned: novel-view augmentation) and the per-ray targets the step graph
// takes besides the pixels' colours.
#include <cstddef>
#include <cstdint>
#include <random>
#include <vector>

#include "nova/model/scene.hpp"
#include "nova/train/disparity_fit.hpp"
#include "nova/train/pixel_batch.hpp"
#include "nova/train/train_config.hpp"

namespace nova::detail {

struct StepBatch {
  size_t frame = 0;  // index into Scene::frames
  bool augmented = false;
  PixelBatch pixels;
  std::vector<Camera> cameras;      // one per NeRF
  std::vector<Image8> nerf_images;  // each NeRF's target image when augmented; empty: the frame
};

// Whether joint step `phase_step` is augmented: from augment_start on, every augment_every-th
// step, until augment_stop (0: to the end). Pretraining steps never are.
bool augmented_step(const TrainConfig& config, bool joint, long phase_step);

// Draws the step's frame and `config.rays` pixels: pretraining from background pixels only,
// joint training from every region, augmented on the steps the configuration says.
// `regions` holds each frame's pixel regions (pixel_regions). `nerf_images`: keep each NeRF's
// warped view (the reference's per-NeRF RGB loss needs them).
StepBatch draw_step_batch(const Scene& scene, const std::vector<std::vector<std::vector<uint32_t>>>& regions,
                          const TrainConfig& config, bool joint, long phase_step, int nerfs, bool nerf_images,
                          std::mt19937& rng);

// Rays [first, first + count) of a batch of `rays` rays: one rank's share of the step.
PixelBatch slice_batch(const PixelBatch& batch, size_t rays, size_t first, size_t count);

// The depth term's targets of the batch's `rays` rays: minus the frame's disparity (the NDC
// depth the renderer gives grows as disparity falls), and which rays carry the term.
struct DepthTargets {
  std::vector<float> target, valid;
};
DepthTargets depth_targets(const Frame& frame, const PixelBatch& batch, size_t rays, bool augmented);

// The free-space surface of every pixel of `frame` (row-major), forward-facing scenes (NDC
// with the near plane at 1): the NDC t of the point at camera-space depth 1 / w, w = the
// fitted inverse depth of the pixel's disparity; 1 (infinity) where w <= 0, 0 where the point
// is not beyond the near plane.
std::vector<float> surface_map(const Frame& frame, const DisparityFit& fit);
// free-space-front: every pixel of object k's mask (masks[k] >= 128, k >= 1) takes the object's
// front, the kFrontQuantile quantile (nearest first) of the map's finite values over that mask;
// a pixel in two masks takes the nearer front. The tenth nearest rather than the nearest: a
// blurred disparity map's rim pixels lie behind an object's front, not in front of it, but a
// single pixel's noise can lie anywhere. The quarter and the 3 % nearest were measured on the
// dev seeds and read no better (docs/accuracy-studies.md).
inline constexpr double kFrontQuantile = 0.1;
void to_object_fronts(std::vector<float>& map, const std::vector<Image8>& masks);
// The values of a row-major plane `width` pixels wide (a frame's disparity, its surface_map) at
// the batch's first `rays` pixels.
std::vector<float> values_at_pixels(const std::vector<float>& plane, int width, const PixelBatch& batch, size_t rays);

// Each NeRF's target colour of every ray [nerfs, rays, 3]: from its own warped view, or the
// frame where `nerf_images` is empty.
std::vector<float> nerf_rgb_targets(const Frame& frame, const std::vector<Image8>& nerf_images,
                                    const PixelBatch& batch, int nerfs, size_t rays);

}  // namespace nova::detail

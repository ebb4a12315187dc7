#include "train/step_batch.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include "nova/sampling/camera.hpp"
#include "nova/train/augment.hpp"
#include "train/percentile.hpp"

namespace nova::detail {

bool augmented_step(const TrainConfig& c, bool joint, long phase_step) {
  return joint && c.augment && phase_step >= c.augment_start && (c.augment_stop == 0 || phase_step < c.augment_stop) &&
         (phase_step - c.augment_start) % c.augment_every == 0;
}

StepBatch draw_step_batch(const Scene& scene, const std::vector<std::vector<std::vector<uint32_t>>>& regions,
                          const TrainConfig& c, bool joint, long phase_step, int nerfs, bool want_nerf_images,
                          std::mt19937& rng) {
  const size_t F = scene.frames.size();
  size_t fi = static_cast<size_t>(uniform01(rng) * static_cast<float>(F)) % F;
  // Pretraining only sees background pixels: skip frames that have none.
  if (!joint)
    for (size_t tries = 0; regions[fi][0].empty() && tries < F; ++tries) fi = (fi + 1) % F;
  const Frame& frame = scene.frames[fi];

  bool augmented = augmented_step(c, joint, phase_step);
  PixelBatch batch;
  std::vector<Camera> cameras(static_cast<size_t>(nerfs), frame.camera);
  RimRays rim;
  if (joint) {
    rim.share = c.rim_rays;
    rim.reach = std::max(1, static_cast<int>(std::lround(c.rim_width * static_cast<float>(frame.rgb.width))));
  }
  // The image each NeRF's own target colour comes from (the per-NeRF RGB loss under the
  // reference conventions): the frame, or on an augmented step each object's warped view.
  std::vector<Image8> nerf_images;
  bool drawn = false;
  // Two objects turned in opposite directions can leave no pixel that both warps cover
  // (a 20 degree turn shifts a 160 px wide image by ~64 px): draw new turns a few times,
  // then fall back to the original view.
  for (int attempt = 0; augmented && !drawn && attempt < 4; ++attempt) {
    std::vector<std::optional<CameraRotation>> rot;
    for (int k = 0; k < scene.num_objects; ++k) rot.push_back(random_rotation(rng, c.augment_degrees));
    AugmentedFrame af = augment_frame(frame, rot);
    Image8 valid = af.valid[0];
    for (size_t k = 1; k < af.valid.size(); ++k)
      for (size_t i = 0; i < valid.data.size(); ++i) valid.data[i] = std::min(valid.data[i], af.valid[k].data[i]);
    const auto warped = pixel_regions(af.masks, &valid);
    size_t usable = 0;
    for (const auto& r : warped) usable += r.size();
    if (usable < static_cast<size_t>(c.rays) / 4) continue;
    batch = draw_pixels(af.rgb, af.masks, warped, c.rays, rng, rim);
    cameras = af.cameras;
    if (want_nerf_images) nerf_images = std::move(af.images);
    drawn = true;
  }
  if (!drawn && joint) {
    augmented = false;
    batch = draw_pixels(frame.rgb, frame.masks, regions[fi], c.rays, rng, rim);
  } else if (!drawn) {
    const auto& r = regions[fi];
    std::vector<std::vector<uint32_t>> background_only(r.size());
    background_only[0] = r[0];
    batch = draw_pixels(frame.rgb, frame.masks, background_only, c.rays, rng);
  }

  StepBatch out;
  out.frame = fi;
  out.augmented = augmented;
  out.pixels = std::move(batch);
  out.cameras = std::move(cameras);
  out.nerf_images = std::move(nerf_images);
  return out;
}

PixelBatch slice_batch(const PixelBatch& batch, size_t R, size_t a, size_t n) {
  PixelBatch mine;
  mine.pixels.assign(batch.pixels.begin() + 2 * a, batch.pixels.begin() + 2 * (a + n));
  mine.rgb.assign(batch.rgb.begin() + 3 * a, batch.rgb.begin() + 3 * (a + n));
  for (size_t k = 0; k < batch.masks.size() / R; ++k)
    mine.masks.insert(mine.masks.end(), batch.masks.begin() + k * R + a, batch.masks.begin() + k * R + a + n);
  mine.region_rays = batch.region_rays;
  return mine;
}

DepthTargets depth_targets(const Frame& frame, const PixelBatch& batch, size_t R, bool augmented) {
  // A warped (augmented) view has no disparity map, so its rays carry no depth term.
  DepthTargets d{std::vector<float>(R, 0.0f), std::vector<float>(R, augmented ? 0.0f : 1.0f)};
  if (!augmented) {
    d.target = values_at_pixels(frame.disparity.data, frame.disparity.width, batch, R);
    for (float& v : d.target) v = -v;
  }
  return d;
}

std::vector<float> surface_map(const Frame& frame, const DisparityFit& fit) {
  const int W = frame.disparity.width, H = frame.disparity.height;
  std::vector<float> map(static_cast<size_t>(W) * H);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const size_t i = static_cast<size_t>(y) * W + x;
      const double w = fit.inverse_depth(frame.disparity.data[i]);
      if (!(w > 0.0)) {
        map[i] = 1.0f;
        continue;
      }
      // NDC t of a world point is 1 + near / z (kernels/sampling.cl), near = 1.
      const double z = camera_unproject(frame.camera, x, y, 1.0 / w)[2];
      map[i] = z < -1.0 ? static_cast<float>(1.0 + 1.0 / z) : 0.0f;
    }
  return map;
}

void to_object_fronts(std::vector<float>& map, const std::vector<Image8>& masks) {
  std::vector<float> front(map.size(), 2.0f);  // 2: no object's
  std::vector<float> t;
  for (size_t k = 1; k < masks.size(); ++k) {
    t.clear();
    for (size_t i = 0; i < map.size(); ++i)
      if (masks[k].data[i] >= 128 && map[i] > 0.0f && map[i] < 1.0f) t.push_back(map[i]);
    if (t.empty()) continue;
    const float f = percentile(t, kFrontQuantile);
    for (size_t i = 0; i < map.size(); ++i)
      if (masks[k].data[i] >= 128) front[i] = std::min(front[i], f);
  }
  for (size_t i = 0; i < map.size(); ++i)
    if (front[i] < 2.0f) map[i] = front[i];
}

std::vector<float> values_at_pixels(const std::vector<float>& plane, int width, const PixelBatch& batch, size_t rays) {
  std::vector<float> v(rays);
  for (size_t r = 0; r < rays; ++r) {
    const size_t x = static_cast<size_t>(batch.pixels[2 * r]), y = static_cast<size_t>(batch.pixels[2 * r + 1]);
    v[r] = plane[y * static_cast<size_t>(width) + x];
  }
  return v;
}

std::vector<float> nerf_rgb_targets(const Frame& frame, const std::vector<Image8>& nerf_images,
                                    const PixelBatch& batch, int nerfs, size_t R) {
  const size_t N = static_cast<size_t>(nerfs);
  std::vector<float> target(N * R * 3);
  for (size_t n = 0; n < N; ++n) {
    const Image8& img = nerf_images.empty() ? frame.rgb : nerf_images[n];
    for (size_t r = 0; r < R; ++r) {
      const int x = static_cast<int>(batch.pixels[2 * r]), y = static_cast<int>(batch.pixels[2 * r + 1]);
      for (int k = 0; k < 3; ++k) target[(n * R + r) * 3 + k] = img.at(x, y, k) / 255.0f;
    }
  }
  return target;
}

}  // namespace nova::detail

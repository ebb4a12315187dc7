#include "nova/train/pixel_batch.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <sstream>

#include "nova/runtime/error.hpp"
#include "train/square_min.hpp"

namespace nova {

float uniform01(std::mt19937& rng) { return static_cast<float>(rng() >> 8) * 0x1.0p-24f; }

std::vector<std::vector<uint32_t>> pixel_regions(const std::vector<Image8>& masks, const Image8* valid) {
  if (masks.empty()) throw Error("pixel_regions: no masks", kExitInternal);
  const int w = masks[0].width, h = masks[0].height;
  std::vector<std::vector<uint32_t>> regions(masks.size());
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (valid && valid->at(x, y) < 128) continue;
      size_t best = 0;
      int best_value = 127;
      for (size_t k = 1; k < masks.size(); ++k)
        if (masks[k].at(x, y) > best_value) {
          best_value = masks[k].at(x, y);
          best = k;
        }
      regions[best].push_back(static_cast<uint32_t>(y) * w + x);
    }
  return regions;
}

std::vector<uint32_t> rim_pixels(const std::vector<std::vector<uint32_t>>& regions, int width, int height,
                                 int reach) {
  const size_t W = static_cast<size_t>(width), H = static_cast<size_t>(height);
  // 0 on the objects' pixels, 1 elsewhere: a square's minimum is 0 where it holds an object pixel.
  std::vector<float> not_object(W * H, 1.0f);
  for (size_t k = 1; k < regions.size(); ++k)
    for (uint32_t p : regions[k]) not_object[p] = 0.0f;
  const std::vector<float> near = detail::square_min(not_object, W, H, reach);
  std::vector<uint32_t> rim;
  for (uint32_t p : regions[0])
    if (near[p] == 0.0f) rim.push_back(p);
  return rim;
}

std::vector<uint32_t> background_apart(const std::vector<std::vector<uint32_t>>& regions, int width, int height,
                                       int reach) {
  if (reach <= 0 || regions.empty()) return regions.empty() ? std::vector<uint32_t>{} : regions[0];
  // rim_pixels keeps regions[0]'s order, so one merge pass leaves out its pixels.
  const std::vector<uint32_t> rim = rim_pixels(regions, width, height, reach);
  std::vector<uint32_t> kept;
  kept.reserve(regions[0].size() - rim.size());
  size_t r = 0;
  for (uint32_t p : regions[0]) {
    if (r < rim.size() && rim[r] == p) {
      ++r;
      continue;
    }
    kept.push_back(p);
  }
  return kept;
}

PixelBatch draw_pixels(const Image8& rgb, const std::vector<Image8>& masks,
                       const std::vector<std::vector<uint32_t>>& regions, int rays, std::mt19937& rng,
                       const RimRays& rim_rays) {
  std::vector<size_t> present;
  for (size_t k = 0; k < regions.size(); ++k)
    if (!regions[k].empty()) present.push_back(k);
  if (present.empty()) throw Error("draw_pixels: no pixel to draw from", kExitInternal);
  PixelBatch b;
  b.region_rays.assign(regions.size(), 0);
  const int share = rays / static_cast<int>(present.size());
  for (size_t k : present) b.region_rays[k] = share;
  b.region_rays[present.front()] += rays - share * static_cast<int>(present.size());

  const size_t R = static_cast<size_t>(rays), N = masks.size();
  b.pixels.resize(R * 2);
  b.rgb.resize(R * 3);
  b.masks.resize(N * R);
  // The background's rays drawn from the ring about the objects: the first `from_rim` of them.
  std::vector<uint32_t> rim;
  int from_rim = 0;
  const bool objects = std::any_of(regions.begin() + 1, regions.end(), [](const auto& r) { return !r.empty(); });
  if (rim_rays.share > 0.0f && objects && !regions[0].empty()) {
    rim = rim_pixels(regions, rgb.width, rgb.height, rim_rays.reach);
    if (!rim.empty()) from_rim = static_cast<int>(std::lround(rim_rays.share * static_cast<float>(b.region_rays[0])));
  }
  size_t r = 0;
  for (size_t k = 0; k < regions.size(); ++k)
    for (int n = 0; n < b.region_rays[k]; ++n, ++r) {
      const auto& region = k == 0 && n < from_rim ? rim : regions[k];
      const uint32_t p = region[static_cast<size_t>(uniform01(rng) * static_cast<float>(region.size())) % region.size()];
      const int x = static_cast<int>(p % static_cast<uint32_t>(rgb.width));
      const int y = static_cast<int>(p / static_cast<uint32_t>(rgb.width));
      b.pixels[r * 2] = static_cast<float>(x);
      b.pixels[r * 2 + 1] = static_cast<float>(y);
      for (int c = 0; c < 3; ++c) b.rgb[r * 3 + c] = rgb.at(x, y, c) / 255.0f;
      for (size_t m = 0; m < N; ++m) b.masks[m * R + r] = masks[m].at(x, y) / 255.0f;
    }
  return b;
}

std::string rng_state(const std::mt19937& rng) {
  std::ostringstream s;
  s << rng;
  return s.str();
}

void set_rng_state(std::mt19937& rng, const std::string& state) {
  std::istringstream s(state);
  std::mt19937 r;
  s >> r;
  if (!s) throw Error("checkpoint: the random-number state is malformed");
  rng = r;
}

}  // namespace nova

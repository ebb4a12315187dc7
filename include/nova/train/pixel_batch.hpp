#pragma once
// Pixel batches of one training step and the random numbers a step consumes, all drawn on
// the host from one generator whose state a checkpoint stores (exact resume).
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "nova/model/scene.hpp"

namespace nova {

// Uniform in [0, 1) from 24 random bits: the same numbers on every standard library, and no
// distribution state to save.
float uniform01(std::mt19937& rng);

struct PixelBatch {
  std::vector<float> pixels;  // [R, 2]: column, row
  std::vector<float> rgb;     // [R, 3] in [0, 1]
  std::vector<float> masks;   // [N, R] in [0, 1]; masks[0] = background
  std::vector<int> region_rays;  // rays drawn from each region (background, objects)
};

// Pixel regions: a pixel belongs to the object whose mask is largest there when that mask
// is >= 128, else to the background. `valid` (optional, 0/255) excludes pixels.
std::vector<std::vector<uint32_t>> pixel_regions(const std::vector<Image8>& masks,
                                                 const Image8* valid = nullptr);

// The background pixels (regions[0]) within `reach` pixels (along rows and columns, a square
// about each pixel) of an object's pixel (regions[1..]): the ring just outside the objects'
// silhouettes, in regions[0]'s order.
std::vector<uint32_t> rim_pixels(const std::vector<std::vector<uint32_t>>& regions, int width, int height,
                                 int reach);

// The background (regions[0]) less its pixels within `reach` of an object's pixel
// (rim_pixels), in its order: a mask that misses its object's edge by a pixel or two (eroded,
// or a segmentation's soft border) would otherwise teach the static NeRF the object's rim as
// background along the object's path. reach 0: regions[0] as it is.
std::vector<uint32_t> background_apart(const std::vector<std::vector<uint32_t>>& regions, int width, int height,
                                       int reach);

// Where the background's rays come from. Spread evenly over a frame, they rarely fall just
// outside a small object, where an object NeRF's density spread past its silhouette shows
// as a haze: `share` of them are drawn from the ring rim_pixels(regions, ..., reach) instead
// (when the frame has an object pixel and the ring a pixel).
struct RimRays {
  float share = 0.0f;
  int reach = 0;
};

// `rays` pixels: an equal share for each non-empty region (the remainder to the first
// non-empty one), uniform with replacement inside it, so that small objects get as many
// rays as the background. `regions` from pixel_regions on the same masks.
PixelBatch draw_pixels(const Image8& rgb, const std::vector<Image8>& masks,
                       const std::vector<std::vector<uint32_t>>& regions, int rays,
                       std::mt19937& rng, const RimRays& rim = {});

// The generator's full state as text, and back (Error on malformed text).
std::string rng_state(const std::mt19937& rng);
void set_rng_state(std::mt19937& rng, const std::string& state);

}  // namespace nova

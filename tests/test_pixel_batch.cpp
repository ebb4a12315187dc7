// A training step's pixel regions and draws (pixel_batch.hpp): the regions against a
// brute-force reading of the masks, and how the rays are shared among them.
#include <boost/test/unit_test.hpp>
#include <set>

#include "nova/train/pixel_batch.hpp"

using namespace nova;

namespace {

constexpr int kW = 23, kH = 17;

// A background mask and two objects: a 4 x 3 block and a single pixel at the right edge.
std::vector<Image8> masks() {
  std::vector<Image8> m(3, Image8(kW, kH, 1, 0));
  for (int y = 5; y < 8; ++y)
    for (int x = 6; x < 10; ++x) m[1].at(x, y) = 255;
  m[2].at(kW - 1, 12) = 200;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) m[0].at(x, y) = (m[1].at(x, y) < 128 && m[2].at(x, y) < 128) ? 255 : 0;
  return m;
}

Image8 picture() {
  Image8 rgb(kW, kH, 3, 0);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x)
      for (int c = 0; c < 3; ++c) rgb.at(x, y, c) = static_cast<uint8_t>((x * 7 + y * 11 + c * 5) % 256);
  return rgb;
}

// The region of pixel (x, y) as the masks say.
int owner(const std::vector<Image8>& m, int x, int y) { return m[1].at(x, y) >= 128 ? 1 : m[2].at(x, y) >= 128 ? 2 : 0; }

}  // namespace

BOOST_AUTO_TEST_SUITE(pixel_batch)

// Every valid pixel in its owner's region, invalid pixels in none.
BOOST_AUTO_TEST_CASE(regions_follow_the_masks) {
  const std::vector<Image8> m = masks();
  Image8 valid(kW, kH, 1, 255);
  for (int x = 0; x < kW; ++x) valid.at(x, 6) = 0;  // a row through the block
  for (const Image8* v : {static_cast<const Image8*>(nullptr), static_cast<const Image8*>(&valid)}) {
    const auto regions = pixel_regions(m, v);
    BOOST_TEST_REQUIRE(regions.size() == 3u);
    std::vector<std::set<uint32_t>> want(3);
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x)
        if (!v || v->at(x, y) >= 128) want[static_cast<size_t>(owner(m, x, y))].insert(static_cast<uint32_t>(y * kW + x));
    for (size_t k = 0; k < 3; ++k)
      BOOST_TEST((std::set<uint32_t>(regions[k].begin(), regions[k].end()) == want[k]), "region " << k);
  }
  BOOST_TEST(pixel_regions(m, &valid)[1].size() == 8u);
}

// Each region draws an equal share (the remainder to the first), every ray from its own
// region, with the pixel's colour and every mask's value; a region without pixels draws none.
BOOST_AUTO_TEST_CASE(regions_share_the_rays) {
  const std::vector<Image8> m = masks();
  const Image8 rgb = picture();
  const auto regions = pixel_regions(m);
  std::mt19937 rng(7);
  const PixelBatch b = draw_pixels(rgb, m, regions, 101, rng);
  BOOST_TEST(b.region_rays == std::vector<int>({35, 33, 33}));
  size_t ray = 0;
  for (size_t k = 0; k < b.region_rays.size(); ++k)
    for (int n = 0; n < b.region_rays[k]; ++n, ++ray) {
      const int x = static_cast<int>(b.pixels[ray * 2]), y = static_cast<int>(b.pixels[ray * 2 + 1]);
      BOOST_TEST(owner(m, x, y) == static_cast<int>(k), "ray " << ray << " of region " << k);
      for (int ch = 0; ch < 3; ++ch) BOOST_TEST(b.rgb[ray * 3 + ch] == rgb.at(x, y, ch) / 255.0f);
      for (size_t o = 0; o < m.size(); ++o) BOOST_TEST(b.masks[o * 101 + ray] == m[o].at(x, y) / 255.0f);
    }
  std::vector<Image8> empty(3, Image8(kW, kH, 1, 0));
  empty[0] = Image8(kW, kH, 1, 255);
  std::mt19937 again(7);
  BOOST_TEST(draw_pixels(rgb, empty, pixel_regions(empty), 10, again).region_rays == std::vector<int>({10, 0, 0}));
}

BOOST_AUTO_TEST_SUITE_END()

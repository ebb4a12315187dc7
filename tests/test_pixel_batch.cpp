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

// The ring against a brute-force reading: background pixels whose square of half-width
// `reach` holds an object pixel.
BOOST_AUTO_TEST_CASE(rim_is_the_background_next_to_the_objects) {
  const std::vector<Image8> m = masks();
  const auto regions = pixel_regions(m);
  for (int reach : {0, 1, 2, 5}) {
    std::set<uint32_t> want;
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        if (owner(m, x, y) != 0) continue;
        bool hit = false;
        for (int dy = -reach; dy <= reach; ++dy)
          for (int dx = -reach; dx <= reach; ++dx) {
            const int xx = x + dx, yy = y + dy;
            if (xx >= 0 && xx < kW && yy >= 0 && yy < kH && owner(m, xx, yy) != 0) hit = true;
          }
        if (hit) want.insert(static_cast<uint32_t>(y * kW + x));
      }
    const std::vector<uint32_t> rim = rim_pixels(regions, kW, kH, reach);
    BOOST_TEST(std::set<uint32_t>(rim.begin(), rim.end()) == want, "reach " << reach);
    BOOST_TEST(rim.size() == want.size(), "reach " << reach << ": no pixel twice");
  }
  // The block's ring at reach 1 is 6 x 5 - 4 x 3 = 18 pixels, the edge pixel's 2 x 3 - 1 = 5.
  BOOST_TEST(rim_pixels(regions, kW, kH, 1).size() == 23u);
}

// background_apart: the background less the ring rim_pixels gives, in the background's order;
// reach 0 keeps it whole.
BOOST_AUTO_TEST_CASE(background_apart_leaves_out_the_ring) {
  const std::vector<Image8> m = masks();
  const auto regions = pixel_regions(m);
  BOOST_TEST(background_apart(regions, kW, kH, 0) == regions[0]);
  for (int reach : {1, 2, 5}) {
    const std::vector<uint32_t> rim = rim_pixels(regions, kW, kH, reach);
    const std::set<uint32_t> ring(rim.begin(), rim.end());
    std::vector<uint32_t> want;
    for (uint32_t p : regions[0])
      if (!ring.count(p)) want.push_back(p);
    const std::vector<uint32_t> got = background_apart(regions, kW, kH, reach);
    BOOST_TEST(got == want, "reach " << reach);
    BOOST_TEST(got.size() + rim.size() == regions[0].size(), "reach " << reach);
  }
}

// With RimRays the background's first share of rays lies in the ring, the rest anywhere in
// the background; the objects' rays are drawn as before; no objects, no ring.
BOOST_AUTO_TEST_CASE(rim_rays_come_from_the_ring) {
  const std::vector<Image8> m = masks();
  const Image8 rgb = picture();
  const auto regions = pixel_regions(m);
  const std::vector<uint32_t> rim = rim_pixels(regions, kW, kH, 2);
  const std::set<uint32_t> ring(rim.begin(), rim.end());
  std::mt19937 rng(7);
  const PixelBatch b = draw_pixels(rgb, m, regions, 101, rng, RimRays{0.4f, 2});
  BOOST_TEST(b.region_rays == std::vector<int>({35, 33, 33}));
  int in_ring = 0, beyond = 0;
  for (int ray = 0; ray < 101; ++ray) {
    const int x = static_cast<int>(b.pixels[ray * 2]), y = static_cast<int>(b.pixels[ray * 2 + 1]);
    const int region = ray < 35 ? 0 : ray < 68 ? 1 : 2;
    BOOST_TEST(owner(m, x, y) == region, "ray " << ray);
    const bool near = ring.count(static_cast<uint32_t>(y * kW + x)) > 0;
    if (ray < 14) BOOST_TEST(near, "ray " << ray << " is one of the ring's 14 (0.4 of 35)");
    if (ray >= 14 && ray < 35) (near ? in_ring : beyond) += 1;
    for (size_t o = 0; o < m.size(); ++o) BOOST_TEST(b.masks[o * 101 + ray] == m[o].at(x, y) / 255.0f);
  }
  // The ring is 58 of the background's 378 pixels: the other 21 rays fall mostly beyond it.
  BOOST_TEST(beyond > in_ring);
  std::vector<Image8> empty(3, Image8(kW, kH, 1, 0));
  empty[0] = Image8(kW, kH, 1, 255);
  std::mt19937 a(7), c(7);
  const PixelBatch plain = draw_pixels(rgb, empty, pixel_regions(empty), 10, a);
  const PixelBatch ringed = draw_pixels(rgb, empty, pixel_regions(empty), 10, c, RimRays{0.5f, 2});
  BOOST_TEST(plain.pixels == ringed.pixels);
}

BOOST_AUTO_TEST_SUITE_END()

// Depth targets at objects' rims (object_depth_rims.hpp): the window maximum against a
// brute-force reading of the masks, and a blurred step put back at the rim.
#include <boost/test/unit_test.hpp>
#include <cmath>

#include "nova/train/object_depth_rims.hpp"
#include "nova/train/step_graphs.hpp"
#include "nova/train/trainer.hpp"
#include "harness.hpp"
#include "nova/data/scene_io.hpp"
#include "scene_test_util.hpp"

using namespace nova;

namespace {

constexpr int kW = 31, kH = 19;

// Background disparity 0.2 with a ramp; object 1 an 8 x 6 block at 0.5 whose values vary, object
// 2 a 3 x 3 block touching the right edge at 0.9; both under a 3-tap blur, so the objects'
// rims read between them and the background as a depth network's map does.
Frame frame() {
  Frame f;
  f.masks.assign(3, Image8(kW, kH, 1, 0));
  ImageF sharp{kW, kH, std::vector<float>(size_t(kW) * kH)};
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      float v = 0.2f + 0.001f * static_cast<float>(x);
      if (x >= 6 && x < 14 && y >= 5 && y < 11) {
        f.masks[1].at(x, y) = 255;
        v = 0.5f + 0.01f * static_cast<float>((x * 3 + y) % 5);
      }
      if (x >= kW - 3 && y >= 12 && y < 15) {
        f.masks[2].at(x, y) = 200;
        v = 0.9f;
      }
      sharp.data[size_t(y) * kW + x] = v;
    }
  f.disparity = sharp;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      double s = 0;
      int n = 0;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int u = x + dx, v = y + dy;
          if (u < 0 || v < 0 || u >= kW || v >= kH) continue;
          s += sharp.data[size_t(v) * kW + u];
          ++n;
        }
      f.disparity.data[size_t(y) * kW + x] = static_cast<float>(s / n);
    }
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) f.masks[0].at(x, y) = (f.masks[1].at(x, y) < 128 && f.masks[2].at(x, y) < 128) ? 255 : 0;
  return f;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(object_depth_rims)

// Each mask pixel is the largest of its own mask's values in the (2r + 1)^2 window, or its own
// when larger (two masks); pixels of no object keep theirs. Exact: a maximum of the same floats.
BOOST_AUTO_TEST_CASE(window_maximum_over_each_mask) {
  const Frame f = frame();
  for (int r : {0, 1, 2, 5, 40}) {
    const ImageF out = object_rim_disparity(f, r);
    BOOST_REQUIRE_EQUAL(out.data.size(), f.disparity.data.size());
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        float want = f.disparity.data[size_t(y) * kW + x];
        for (size_t k = 1; k < f.masks.size(); ++k) {
          if (f.masks[k].at(x, y) < 128) continue;
          for (int v = std::max(0, y - r); v <= std::min(kH - 1, y + r); ++v)
            for (int u = std::max(0, x - r); u <= std::min(kW - 1, x + r); ++u)
              if (f.masks[k].at(u, v) >= 128) want = std::max(want, f.disparity.data[size_t(v) * kW + u]);
        }
        BOOST_TEST_CONTEXT("radius " << r << " pixel (" << x << ", " << y << ")")
        BOOST_TEST(out.data[size_t(y) * kW + x] == want);
      }
  }
}

// The point of it: at radius 2 every pixel of the block reads at least what its interior reads
// (the blur takes the rims part way to the background), never more than the block's largest.
BOOST_AUTO_TEST_CASE(blurred_rims_raised_to_the_interior) {
  const Frame f = frame();
  const ImageF out = object_rim_disparity(f, 2);
  float interior_min = 1.0f, mask_max = 0.0f, rim_before = 1.0f;
  for (int y = 5; y < 11; ++y)
    for (int x = 6; x < 14; ++x) {
      const float d = f.disparity.data[size_t(y) * kW + x];
      mask_max = std::max(mask_max, d);
      if (x > 6 && x < 13 && y > 5 && y < 10) interior_min = std::min(interior_min, d);
      else rim_before = std::min(rim_before, d);
    }
  BOOST_REQUIRE_LT(rim_before, 0.45f);  // the blur did pull the rim back
  for (int y = 5; y < 11; ++y)
    for (int x = 6; x < 14; ++x) {
      BOOST_TEST(out.data[size_t(y) * kW + x] >= interior_min);
      BOOST_TEST(out.data[size_t(y) * kW + x] <= mask_max);
    }
}

BOOST_AUTO_TEST_CASE(radius_from_the_width) {
  BOOST_TEST(object_rim_radius(0.0, 480) == 0);
  BOOST_TEST(object_rim_radius(0.02, 160) == 3);
  BOOST_TEST(object_rim_radius(0.02, 480) == 10);
  BOOST_TEST(object_rim_radius(0.001, 64) == 1);  // a positive fraction keeps at least one pixel
  Frame none;
  BOOST_TEST(object_rim_disparity(none, 3).empty());  // no disparity: nothing to raise
}

// The free-space term reads a target of its own only with the option and the term on; the
// depth term keeps the disparity as given.
BOOST_AUTO_TEST_CASE(free_space_term_takes_its_own_target) {
  RayGeometry geo;
  geo.num_objects = 2;
  geo.frames = 6;
  geo.ndc = true;
  geo.disparity = true;
  TrainConfig c = preset_config("quick");
  c.rays = 8;
  c.samples = 4;
  BOOST_REQUIRE(c.w_free_space > 0.0f);
  BOOST_TEST(!build_joint_graph(c, geo)->target_free_space.valid());
  c.object_depth_rim = 0.025f;
  const auto g = build_joint_graph(c, geo);
  BOOST_TEST(g->target_free_space.valid());
  BOOST_TEST(g->target_depth.valid());
  BOOST_TEST(g->target_free_space.id != g->target_depth.id);
  c.w_free_space = 0.0f;
  BOOST_TEST(!build_joint_graph(c, geo)->target_free_space.valid());
}

// The first joint step of the tiny scene from the same parameters and draws: raised targets
// only lower the free-space penalty (the fitted depth grows with minus the disparity), and the
// tiny scene's objects have rims the window raises, so it is lower.
BOOST_AUTO_TEST_CASE(raised_rims_lower_the_free_space_term) {
  LoadOptions o;
  const Scene scene = load_scene(nova::test::cached_tiny_scene().string(), o);
  BOOST_REQUIRE(!scene.frames[0].disparity.empty());
  const auto first_joint_free_space = [&](float rim) {
    TrainConfig c = preset_config("quick");
    c.pretrain_steps = 3;
    c.steps = 1;
    c.augment_start = 10;
    c.occupancy = false;
    c.log_every = 1;
    c.checkpoint_every = 1000;
    c.object_depth_rim = rim;
    nova::test::TempDir dir("depth-rims");
    Trainer t(nova::test::runtime(), scene, c, (dir / "run").string());
    double v = -1;
    t.run([&](const TrainProgress& p) {
      for (const auto& [name, value] : p.terms)
        if (p.phase == "joint" && name == "free_space") v = value;
    });
    return v;
  };
  const double plain = first_joint_free_space(0.0f), raised = first_joint_free_space(0.05f);
  BOOST_TEST_MESSAGE("free-space term at the first joint step: " << plain << " as given, " << raised << " raised");
  BOOST_REQUIRE(plain > 0.0);
  BOOST_TEST(raised >= 0.0);
  BOOST_TEST(raised < plain);
}

BOOST_AUTO_TEST_SUITE_END()

// generate_rays and stratified_samples: closed forms of the conventions (camera.hpp, the
// reference's ndc_rays), samples with and without jitter against float64 host references with
// their layout and strata, the layout contract with positional_encoding / build_mlp /
// render_composite, and refused inputs. The rays' and instance_points' values against float64
// at other cameras and sizes are the op table's rays_and_samples and instance_points entries
// (tests/op_table_render.cpp).
#include <boost/test/unit_test.hpp>
#include <array>
#include <cmath>

#include "harness.hpp"
#include "nova/model/mlp.hpp"
#include "nova/ops/encoding/positional_encoding.hpp"
#include "nova/sampling/rays.hpp"
#include "nova/render/render_composite.hpp"
#include "nova/model/compose_spec.hpp"
#include "nova/graph/executor.hpp"
#include "rays_reference.hpp"

using namespace nova;
using namespace nova::test;

namespace {

struct RayRun {
  std::vector<float> o, d, view;
};

RayRun run_rays(const std::vector<Camera>& cams, const std::vector<float>& pixels, bool ndc) {
  Graph g;
  const size_t R = pixels.size() / 2, N = cams.size();
  Tensor p = g.input("pixels", Shape{R, 2}), c = g.input("cameras", Shape{N, 16});
  RayOptions o;
  o.ndc = ndc;
  Rays rays = generate_rays(p, c, o);
  for (Tensor t : {rays.origins, rays.directions, rays.viewdirs}) g.keep(t);
  Executor ex(runtime(), g);
  ex.set(p, pixels);
  ex.set(c, camera_rows(cams));
  ex.forward();
  return {ex.get(rays.origins), ex.get(rays.directions), ex.get(rays.viewdirs)};
}

}  // namespace

BOOST_AUTO_TEST_SUITE(rays)

// Rays against the float64 reference (metric cameras moved, turned and tilted; NDC rays of
// forward-facing cameras) are the op table's rays_and_samples entry; these are the closed
// forms the conventions promise. The principal point of an unrotated camera looks straight
// down -z.
BOOST_AUTO_TEST_CASE(principal_point_looks_down_minus_z) {
  const RayRun centre = run_rays({make_camera(400, 480, 270, {0.1, -0.2, 0.3}, 0.0, 0.0)}, {240.0f, 135.0f}, false);
  BOOST_TEST(centre.d == (std::vector<float>{0, 0, -1}), boost::test_tools::per_element());
}

// Every NDC origin lies on the near plane, z' = -1, and o + d reaches z' = +1 (infinity):
// within 1e-5, a few ulps of O(1) values after the division by o_z and d_z.
BOOST_AUTO_TEST_CASE(ndc_rays_span_the_near_plane_to_infinity) {
  // Forward-facing: cameras near the origin looking down -z, as LLFF scenes after recentring.
  const std::vector<Camera> cams = {make_camera(420, 480, 270, {0.0, 0.0, 0.0}, 0.0, 0.0),
                                    make_camera(420, 480, 270, {0.05, -0.02, 0.1}, 0.1, 0.05)};
  const RayRun got = run_rays(cams, random_pixels(25, 480, 270, 4), true);
  for (size_t r = 0; r < 50; ++r) {
    BOOST_TEST(std::fabs(got.o[r * 3 + 2] + 1.0f) < 1e-5f);
    BOOST_TEST(std::fabs(got.o[r * 3 + 2] + got.d[r * 3 + 2] - 1.0f) < 1e-5f);
  }
}

namespace {

struct SampleRun {
  std::vector<float> z, delta;
  std::vector<std::vector<float>> positions, viewdirs;
  std::vector<Shape> shapes;
  std::vector<float> o, d, view;
};

SampleRun run_samples(const std::vector<Camera>& cams, const std::vector<float>& pixels,
                      const std::vector<float>& jitter, const SampleOptions& so, bool ndc) {
  Graph g;
  const size_t R = pixels.size() / 2, N = cams.size(), S = so.samples;
  Tensor p = g.input("pixels", Shape{R, 2}), c = g.input("cameras", Shape{N, 16});
  Tensor j = jitter.empty() ? Tensor{} : g.input("jitter", Shape{R, S});
  RayOptions ro;
  ro.ndc = ndc;
  Rays rays = generate_rays(p, c, ro);
  Samples s = stratified_samples(rays, j, so);
  for (Tensor t : {rays.origins, rays.directions, rays.viewdirs, s.z, s.delta}) g.keep(t);
  for (size_t k = 0; k < s.positions.size(); ++k) {
    g.keep(s.positions[k]);
    g.keep(s.viewdirs[k]);
  }
  Executor ex(runtime(), g);
  ex.set(p, pixels);
  ex.set(c, camera_rows(cams));
  if (j.valid()) ex.set(j, jitter);
  ex.forward();
  SampleRun out{ex.get(s.z), ex.get(s.delta), {}, {}, {}, ex.get(rays.origins),
                ex.get(rays.directions), ex.get(rays.viewdirs)};
  for (size_t k = 0; k < s.positions.size(); ++k) {
    out.positions.push_back(ex.get(s.positions[k]));
    out.viewdirs.push_back(ex.get(s.viewdirs[k]));
    out.shapes.push_back(s.positions[k].shape());
  }
  return out;
}

}  // namespace

// Sample tolerance: depths are near + i * step in float32 (atol 1e-6 * far); positions add
// z d to o (atol 1e-5 * scale with metric scales up to 6); spacings are differences of
// neighbouring depths, whose absolute error 1e-6 * far is relative to a gap of
// (far - near) / S, hence rtol 1e-4 there.
BOOST_AUTO_TEST_CASE(stratified_samples_layout_and_values) {
  const std::vector<Camera> cams = {make_camera(400, 64, 48, {0, 0, 4}, 0.0, 0.0),
                                    make_camera(400, 64, 48, {0, 0, 4}, 0.2, 0.0),
                                    make_camera(400, 64, 48, {0, 0, 4}, -0.2, 0.1)};
  const size_t R = 6, S = 16, N = 3;
  const auto pixels = random_pixels(R, 64, 48, 5);
  for (bool jittered : {false, true}) {
    SampleOptions so;
    so.samples = S;
    so.near = 2.0f;
    so.far = 6.0f;
    so.groups = {1, 2};
    const auto jitter = jittered ? random_floats(R * S, 0, 1, 6) : std::vector<float>{};
    const SampleRun s = run_samples(cams, pixels, jitter, so, false);
    BOOST_TEST(s.shapes[0].str() == "[96, 3]");
    BOOST_TEST(s.shapes[1].str() == "[2, 96, 3]");
    const auto z = ref_depths(R, S, 2.0, 6.0, jitter);
    expect_close(s.z, z, 6e-6, 1e-6, "z");
    std::vector<double> delta, pos0, pos1, view1;
    for (size_t n = 0; n < N; ++n)
      for (size_t r = 0; r < R; ++r) {
        const float* d = &s.d[(n * R + r) * 3];
        const double norm = std::sqrt(double(d[0]) * d[0] + double(d[1]) * d[1] + double(d[2]) * d[2]);
        for (size_t i = 0; i < S; ++i) {
          const double zi = z[r * S + i];
          delta.push_back((i + 1 < S ? z[r * S + i + 1] - zi : 1e10) * norm);
          for (int k = 0; k < 3; ++k) {
            const double p = s.o[(n * R + r) * 3 + k] + zi * d[k];
            (n == 0 ? pos0 : pos1).push_back(p);
            if (n > 0) view1.push_back(s.view[(n * R + r) * 3 + k]);
          }
        }
      }
    expect_close(s.delta, delta, 1e-6, 1e-4, "delta");
    expect_close(s.positions[0], pos0, 6e-5, 1e-6, "positions of group 0");
    expect_close(s.positions[1], pos1, 6e-5, 1e-6, "positions of group 1");
    expect_close(s.viewdirs[1], view1, 1e-7, 0, "viewdirs of group 1 (copied)");
    // Strata: every depth inside its own stratum, so depths increase along the ray.
    for (size_t r = 0; r < R; ++r)
      for (size_t i = 1; i < S; ++i) BOOST_TEST(s.z[r * S + i] >= s.z[r * S + i - 1]);
  }
}

// The chain the trainer builds: NDC rays -> samples -> positional_encoding -> MLPs (static
// and a batch of 2 objects) -> stack -> render_composite. Checks that the shapes connect
// without copies or reshapes; runs the encoding and renderer on small data.
BOOST_AUTO_TEST_CASE(samples_plug_into_encoding_mlp_and_renderer) {
  Graph g;
  const size_t R = 8, S = 8;
  Tensor p = g.input("pixels", Shape{R, 2}), c = g.input("cameras", Shape{3, 16});
  Tensor j = g.input("jitter", Shape{R, S});
  RayOptions ro;
  ro.ndc = true;
  Rays rays = generate_rays(p, c, ro);
  SampleOptions so;
  so.samples = S;
  so.groups = {1, 2};
  Samples s = stratified_samples(rays, j, so);
  Tensor enc_static = positional_encoding(s.positions[0], 10);
  Tensor enc_objects = positional_encoding(s.positions[1], 10);
  BOOST_TEST(enc_static.shape().str() == "[64, 63]");
  BOOST_TEST(enc_objects.shape().str() == "[2, 64, 63]");
  MlpConfig one;
  one.depth = 2;
  one.width = 16;
  one.skip = -1;
  one.outputs = kRawChannels;
  MlpConfig two = one;
  two.networks = 2;
  Mlp mlp_static = build_mlp(enc_static, one, "static");
  Mlp mlp_objects = build_mlp(enc_objects, two, "objects");
  BOOST_TEST(mlp_static.output.shape().str() == "[64, 5]");
  BOOST_TEST(mlp_objects.output.shape().str() == "[2, 64, 5]");
  RenderOutputs out = render_composite(stack({mlp_static.output, mlp_objects.output}), s.delta, s.z);
  BOOST_TEST(out.mask.shape().str() == "[3, 8]");
}

BOOST_AUTO_TEST_CASE(rejects_bad_inputs) {
  Graph g;
  Tensor p = g.input("pixels", Shape{4, 3}), c = g.input("cameras", Shape{2, 16});
  BOOST_CHECK_THROW(generate_rays(p, c), Error);
  Tensor p2 = g.input("pixels2", Shape{4, 2});
  Rays rays = generate_rays(p2, c);
  SampleOptions so;
  so.samples = 8;
  so.groups = {1, 2};  // 3 NeRFs for 2 cameras
  BOOST_CHECK_THROW(stratified_samples(rays, Tensor{}, so), Error);
  so.groups = {};
  Tensor bad_jitter = g.input("jitter", Shape{4, 7});
  BOOST_CHECK_THROW(stratified_samples(rays, bad_jitter, so), Error);
}

BOOST_AUTO_TEST_SUITE_END()

// The op table's rendering ops: render_composite (default, reference-code and plain
// options), generate_rays with stratified_samples, and instance_points, over 1009 rays (several
// work-groups, a partial last one) and small cases.
#include <cmath>

#include "nova/sampling/rays.hpp"
#include "nova/render/render_composite.hpp"
#include "op_table.hpp"
#include "rays_reference.hpp"

namespace nova::test {

// render.cl: render_forward / render_backward, one work-item per ray. Variants (dims N NeRFs,
// R rays, S samples[, C channels]):
//   0-2: with density noise; 0 the default options; 1 the reference code's (blend epsilon
//        1e-8, alpha_full as a sum, nerf_depth); 2 plain compositing (one NeRF, no blend).
//   3-6: 3 rays x 64 samples of 1, 2, 4 and 8 NeRFs, 5 or 7 channels (the extra ones take no
//        gradient), a delta per NeRF or one shared, with or without density noise.
//   7, 8: already activated inputs (rgb and blend in [0, 1]; blends kept away from the hard
//        threshold 0.5, a step, so that differences never cross it), soft and hard blending.
//   9: the harness's float32 central differences of the device forward, one output at a time.
// Forward tolerance: atol 2e-6, rtol 1e-5. Each output is a sum of at most S * N float32
// products of values in [0, 1], each with relative rounding about 1e-7, and a transmittance
// that is itself a product of S factors (relative error about S * 6e-8 = 4e-6 at S = 64):
// 1e-5 relative plus 2e-6 absolute covers that with margin while still catching any formula
// slip (a wrong epsilon or normalisation moves outputs by 1e-3 or more). Gradient tolerance
// (against float64 central differences of the reference under the five-term loss,
// render_check.hpp): rtol 1e-3, atol 1e-4 of the gradient scale: the backward has
// cancellations (R_s - G, g_n . c - R_n) of sums of up to S terms, so its float32 error is
// about S * 1e-7 relative to the gradient scale; FD in float64 is accurate to ~1e-9.
// Variant 9: harness default tolerance 2e-2 of the gradient scale with step 1e-2: the FD
// truncation error h^2 f''' / 6 is about 2e-5 and the float32 rounding of the loss
// difference about 1e-7 / 2e-2 = 5e-6 of it, so 2e-2 leaves room without hiding an error.
// The checks are op_table_checks.cpp's.
RenderTableCase render_table_case(const OpShape& s) {
  const int N = static_cast<int>(s.dims[0]), R = static_cast<int>(s.dims[1]), S = static_cast<int>(s.dims[2]);
  if (s.variant <= 2) {
    RenderRefInput in = random_render_case(N, R, S, 5, false, true, 151 + 10 * unsigned(s.variant));
    in.blend_eps = s.variant == 1 ? 1e-8 : in.blend_eps;
    in.alpha_full_sum = in.nerf_depth = s.variant == 1;
    in.no_blend = s.variant == 2;
    return {in, 152 + 10 * unsigned(s.variant)};
  }
  if (s.variant <= 6) {
    const unsigned seed = 11 + 10 * unsigned(s.variant - 3);
    const bool per_nerf_delta = s.variant == 4 || s.variant == 6, noise = s.variant == 4 || s.variant == 5;
    return {random_render_case(N, R, S, static_cast<int>(s.dims[3]), per_nerf_delta, noise, seed), seed + 100};
  }
  if (s.variant == 9) return {random_render_case(N, R, S, 5, true, false, 3), 0};
  RenderRefInput in = random_render_case(N, R, S, 5, false, false, 5);
  const auto u = random_floats(in.raw.size(), 0, 1, 6);
  for (size_t e = 0; e < in.raw.size(); ++e) {
    const size_t ch = e % 5;
    if (ch < 3) in.raw[e] = u[e];
    if (ch == 4) in.raw[e] = u[e] < 0.5f ? u[e] * 0.8 : 0.6 + 0.4 * (u[e] - 0.5f) * 2;
  }
  in.rgb_sigmoid = in.blend_sigmoid = false;
  in.hard_blend = s.variant == 8;
  return {in, 77};
}

RenderGraph render_table_graph(Graph& g, const RenderRefInput& in) {
  const size_t N = in.nerfs, R = in.rays, S = in.samples;
  RenderGraph r;
  r.raw = g.input("raw", Shape{N, R * S, static_cast<size_t>(in.channels)}, true);
  r.delta = in.delta.size() == R * S ? g.input("delta", Shape{R, S}) : g.input("delta", Shape{N, R, S});
  r.z = g.input("z", Shape{R, S});
  r.noise = in.noise.empty() ? Tensor{} : g.input("noise", Shape{N, R * S});
  r.out = render_composite(r.raw, r.delta, r.z, r.noise, render_options(in));
  return r;
}

namespace {

OpEntry render_entry() {
  OpEntry e;
  e.name = "render_composite";
  e.shapes = {{{2, kOddRows, 4}, 0, "2 NeRFs x 1009 rays x 4"},
              {{2, kOddRows, 4}, 1, "reference options, 2 NeRFs x 1009 rays x 4"},
              {{1, kOddRows, 4}, 2, "plain, 1 NeRF x 1009 rays x 4"},
              {{2, 1, 3}, 0, "2 NeRFs x 1 ray x 3"},
              {{1, 3, 64, 5}, 3, "1 NeRF x 3 rays x 64"},
              {{2, 3, 64, 5}, 4, "2 NeRFs x 3 rays x 64, delta per NeRF, noise"},
              {{4, 3, 64, 7}, 5, "4 NeRFs x 3 rays x 64, 7 channels, noise"},
              {{8, 3, 64, 5}, 6, "8 NeRFs x 3 rays x 64, delta per NeRF"},
              {{3, 3, 32}, 7, "activated inputs, soft blending, 3 NeRFs x 3 rays x 32"},
              {{3, 3, 32}, 8, "activated inputs, hard blending, 3 NeRFs x 3 rays x 32"},
              {{2, 2, 16}, 9, "device finite differences, 2 NeRFs x 2 rays x 16, delta per NeRF"}};
  e.build = [](Graph& g, const OpShape& s) {
    const RenderGraph r = render_table_graph(g, render_table_case(s).in);
    std::vector<Tensor> inputs = {r.raw, r.delta, r.z};
    if (r.noise.valid()) inputs.push_back(r.noise);
    return OpGraph{inputs, {r.out.rgb, r.out.mask, r.out.depth}, {}};
  };
  e.values = [](const OpShape& s) {
    const RenderRefInput in = render_table_case(s).in;
    std::vector<std::vector<float>> v = {to_float(in.raw), to_float(in.delta), to_float(in.z)};
    if (!in.noise.empty()) v.push_back(to_float(in.noise));
    return v;
  };
  e.flops = [](const OpShape& s) { return double(s.dims[0] * s.dims[1] * s.dims[2]) * 120; };
  return e;
}

// sampling.cl: rays_generate (2D: rays x cameras), sample_spacing and sample_points. Variant
// 0: three 64 x 48 cameras, metric rays, groups of 1 and 2 NeRFs; 1: three 480 x 270 cameras
// moved, turned and tilted (a second focal length), 25 rays; 2: NDC rays of two
// forward-facing cameras near the origin (as LLFF scenes after recentring), 25 rays, samples
// over t in [0, 1], one NeRF per camera. Tolerances as test_rays: rays atol 1e-6 rtol 1e-6
// (a float32 rotation of O(1) components: a few ulps); NDC origins and directions 1e-5 (the
// mapping divides by o_z and d_z, |d'| up to 2 far from the centre); depths atol 6e-6;
// spacings rtol 1e-4 (neighbouring depths' error against a gap of (far - near) / S);
// positions atol 6e-5 (z d added to o at metric scales up to 6).
struct RaysCase {
  std::vector<Camera> cameras;
  int width, height;
  unsigned pixel_seed;
  bool ndc;
  float near, far;
  std::vector<int> groups;
};

const RaysCase& rays_case(const OpShape& s) {
  static const std::vector<RaysCase> cases = {
      {{make_camera(400, 64, 48, {0, 0, 4}, 0.0, 0.0), make_camera(400, 64, 48, {0, 0, 4}, 0.2, 0.0),
        make_camera(350, 64, 48, {0.5, 0, 4}, -0.2, 0.1)},
       64, 48, 161, false, 2.0f, 6.0f, {1, 2}},
      {{make_camera(400, 480, 270, {0.1, -0.2, 0.3}, 0.0, 0.0), make_camera(400, 480, 270, {0.1, -0.2, 0.3}, 0.3, -0.2),
        make_camera(350, 480, 270, {1.0, 0.5, -2.0}, -0.35, 0.1)},
       480, 270, 3, false, 2.0f, 6.0f, {1, 2}},
      {{make_camera(420, 480, 270, {0.0, 0.0, 0.0}, 0.0, 0.0), make_camera(420, 480, 270, {0.05, -0.02, 0.1}, 0.1, 0.05)},
       480, 270, 4, true, 0.0f, 1.0f, {1, 1}}};
  return cases.at(static_cast<size_t>(s.variant));
}

OpEntry rays_entry() {
  OpEntry e;
  e.name = "rays_and_samples";
  // dims: rays R, samples S.
  e.shapes = {{{kOddRows, 5}, 0, "1009 rays x 3 cameras x 5 samples"},
              {{1, 3}, 0, "1 ray x 3 cameras x 3 samples"},
              {{25, 7}, 1, "25 rays x 3 turned 480 x 270 cameras x 7 samples"},
              {{25, 7}, 2, "NDC, 25 rays x 2 cameras x 7 samples"}};
  e.build = [](Graph& g, const OpShape& s) {
    const RaysCase& rc = rays_case(s);
    const size_t R = s.dims[0], S = s.dims[1], N = rc.cameras.size();
    Tensor tp = g.input("pixels", Shape{R, 2}), tc = g.input("cameras", Shape{N, 16}), tj = g.input("jitter", Shape{R, S});
    RayOptions ro;
    ro.ndc = rc.ndc;
    Rays rays = generate_rays(tp, tc, ro);
    SampleOptions so;
    so.samples = static_cast<int>(S);
    so.near = rc.near;
    so.far = rc.far;
    so.groups = rc.groups;
    Samples sm = stratified_samples(rays, tj, so);
    return OpGraph{{tp, tc, tj}, {rays.origins, rays.directions, rays.viewdirs, sm.z, sm.delta, sm.positions[0], sm.positions[1]}, {}};
  };
  e.values = [](const OpShape& s) {
    const RaysCase& rc = rays_case(s);
    return std::vector<std::vector<float>>{random_pixels(s.dims[0], rc.width, rc.height, rc.pixel_seed),
                                           camera_rows(rc.cameras), random_floats(s.dims[0] * s.dims[1], 0, 1, 162)};
  };
  e.reference = [](const OpCase& c) {
    const RaysCase& rc = rays_case(c.shape);
    const size_t R = c.shape.dims[0], S = c.shape.dims[1], N = rc.cameras.size();
    const auto &pixels = c.values[0], &o = c.outputs[0], &dir = c.outputs[1];
    std::vector<double> o_ref, d_ref, v_ref;
    for (const Camera& cam : rc.cameras)
      for (size_t r = 0; r < R; ++r) {
        const RefRay ref = ref_ray(cam, pixels[2 * r], pixels[2 * r + 1], rc.ndc, 1.0);
        o_ref.insert(o_ref.end(), ref.o.begin(), ref.o.end());
        d_ref.insert(d_ref.end(), ref.d.begin(), ref.d.end());
        v_ref.insert(v_ref.end(), ref.view.begin(), ref.view.end());
      }
    const auto z = ref_depths(R, S, rc.near, rc.far, c.values[2]);
    // Spacings and positions from the device's own directions and origins (checked above).
    std::vector<double> delta, pos0, pos1;
    for (size_t n = 0; n < N; ++n)
      for (size_t r = 0; r < R; ++r) {
        const float* d = &dir[(n * R + r) * 3];
        const double norm = std::sqrt(double(d[0]) * d[0] + double(d[1]) * d[1] + double(d[2]) * d[2]);
        for (size_t i = 0; i < S; ++i) {
          const double zi = z[r * S + i];
          delta.push_back((i + 1 < S ? z[r * S + i + 1] - zi : 1e10) * norm);
          for (int k = 0; k < 3; ++k) (n == 0 ? pos0 : pos1).push_back(o[(n * R + r) * 3 + k] + zi * d[k]);
        }
      }
    const Tolerance ray = rc.ndc ? Tolerance{1e-5, 1e-5} : Tolerance{1e-6, 1e-6};
    // NDC view directions are the world rays' (not the reference's NDC ones): not compared.
    return std::vector<Expected>{{o_ref, ray}, {d_ref, ray}, {rc.ndc ? std::vector<double>{} : v_ref, ray},
                                 {z, {6e-6, 1e-6}}, {delta, {1e-6, 1e-4}}, {pos0, {6e-5, 1e-6}}, {pos1, {6e-5, 1e-6}}};
  };
  e.flops = [](const OpShape& s) { return double(s.dims[0]) * 3 * (40 + 12 * s.dims[1]); };
  return e;
}

}  // namespace

unsigned instance_points_seed(const OpShape& s) { return s.variant == 1 ? 11 : 163; }

namespace {

// instance_points: points x 3 placed instances, NDC and metric, as test_rays
// (rays_reference.hpp states the tolerance: 1e-4 on NDC values in [-2, 2]; the check is
// op_table_checks.cpp's).
OpEntry instance_points_entry() {
  OpEntry e;
  e.name = "instance_points";
  e.shapes = {{{kOddRows}, 0, "1009 points x 3 instances"}, {{1}, 0, "1 point x 3 instances"},
              {{37}, 1, "37 points x 3 instances, other transforms"}};
  e.build = [](Graph& g, const OpShape& s) {
    Tensor pos = g.input("positions", Shape{s.dims[0], 3}), tr = g.input("transforms", Shape{3, 12});
    return OpGraph{{pos, tr}, {instance_points(pos, tr)}, {}};
  };
  e.values = [](const OpShape& s) {
    const unsigned seed = instance_points_seed(s);
    return std::vector<std::vector<float>>{random_floats(s.dims[0] * 3, -0.5f, 0.5f, seed), random_floats(36, -1, 1, seed + 1)};
  };
  e.flops = [](const OpShape& s) { return double(s.dims[0]) * 3 * 30; };
  return e;
}

}  // namespace

void register_render_ops(std::vector<OpEntry>& t) {
  t.push_back(render_entry());
  t.push_back(rays_entry());
  t.push_back(instance_points_entry());
}

}  // namespace nova::test

// The op table's rendering ops: render_composite (default, reference-code and plain
// options), generate_rays with stratified_samples, and instance_points, over 1009 rays (several
// work-groups, a partial last one) and small cases.
#include <cmath>

#include "nova/rays.hpp"
#include "nova/render.hpp"
#include "op_table.hpp"
#include "rays_reference.hpp"

namespace nova::test {

// render.cl: render_forward / render_backward, one work-item per ray, with density noise.
// Variant 0: the default options; 1: the reference code's (blend epsilon 1e-8, alpha_full as
// a sum, nerf_depth); 2: plain compositing (one NeRF, no blend). Tolerances as test_render:
// forward atol 2e-6 rtol 1e-5; gradient against float64 finite differences of the reference,
// rtol 1e-3, atol 1e-4 of the gradient scale (op_table_checks.cpp).
RenderRefInput render_table_case(const OpShape& s) {
  const int N = static_cast<int>(s.dims[0]), R = static_cast<int>(s.dims[1]), S = static_cast<int>(s.dims[2]);
  RenderRefInput in = random_render_case(N, R, S, 5, false, true, 151 + 10 * unsigned(s.variant));
  in.blend_eps = s.variant == 1 ? 1e-8 : in.blend_eps;
  in.alpha_full_sum = in.nerf_depth = s.variant == 1;
  in.no_blend = s.variant == 2;
  return in;
}

namespace {

OpEntry render_entry() {
  OpEntry e;
  e.name = "render_composite";
  // dims: NeRFs N, rays R, samples S.
  e.shapes = {{{2, kOddRows, 4}, 0, "2 NeRFs x 1009 rays x 4"},
              {{2, kOddRows, 4}, 1, "reference options, 2 NeRFs x 1009 rays x 4"},
              {{1, kOddRows, 4}, 2, "plain, 1 NeRF x 1009 rays x 4"},
              {{2, 1, 3}, 0, "2 NeRFs x 1 ray x 3"}};
  e.build = [](Graph& g, const OpShape& s) {
    const size_t N = s.dims[0], R = s.dims[1], S = s.dims[2];
    Tensor raw = g.input("raw", Shape{N, R * S, 5}, true), delta = g.input("delta", Shape{R, S});
    Tensor z = g.input("z", Shape{R, S}), noise = g.input("noise", Shape{N, R * S});
    RenderOutputs out = render_composite(raw, delta, z, noise);
    return OpGraph{{raw, delta, z, noise}, {out.rgb, out.mask, out.depth}, {}};
  };
  e.values = [](const OpShape& s) {
    const RenderRefInput in = render_table_case(s);
    return std::vector<std::vector<float>>{to_float(in.raw), to_float(in.delta), to_float(in.z), to_float(in.noise)};
  };
  e.flops = [](const OpShape& s) { return double(s.dims[0] * s.dims[1] * s.dims[2]) * 120; };
  return e;
}

// sampling.cl: rays_generate (2D: rays x cameras), sample_spacing and sample_points (groups
// of 1 and 2 NeRFs). Tolerances as test_rays: rays atol 1e-6 rtol 1e-6; depths atol 6e-6;
// spacings rtol 1e-4; positions atol 6e-5.
const std::vector<Camera>& cameras() {
  static const std::vector<Camera> c = {make_camera(400, 64, 48, {0, 0, 4}, 0.0, 0.0),
                                        make_camera(400, 64, 48, {0, 0, 4}, 0.2, 0.0),
                                        make_camera(350, 64, 48, {0.5, 0, 4}, -0.2, 0.1)};
  return c;
}

OpEntry rays_entry() {
  OpEntry e;
  e.name = "rays_and_samples";
  // dims: rays R, samples S.
  e.shapes = {{{kOddRows, 5}, 0, "1009 rays x 3 cameras x 5 samples"}, {{1, 3}, 0, "1 ray x 3 cameras x 3 samples"}};
  e.build = [](Graph& g, const OpShape& s) {
    const size_t R = s.dims[0], S = s.dims[1], N = cameras().size();
    Tensor tp = g.input("pixels", Shape{R, 2}), tc = g.input("cameras", Shape{N, 16}), tj = g.input("jitter", Shape{R, S});
    Rays rays = generate_rays(tp, tc);
    SampleOptions so;
    so.samples = static_cast<int>(S);
    so.near = 2.0f;
    so.far = 6.0f;
    so.groups = {1, 2};
    Samples sm = stratified_samples(rays, tj, so);
    return OpGraph{{tp, tc, tj}, {rays.origins, rays.directions, rays.viewdirs, sm.z, sm.delta, sm.positions[0], sm.positions[1]}, {}};
  };
  e.values = [](const OpShape& s) {
    return std::vector<std::vector<float>>{random_pixels(s.dims[0], 64, 48, 161), camera_rows(cameras()),
                                           random_floats(s.dims[0] * s.dims[1], 0, 1, 162)};
  };
  e.reference = [](const OpCase& c) {
    const size_t R = c.shape.dims[0], S = c.shape.dims[1], N = cameras().size();
    const auto &pixels = c.values[0], &o = c.outputs[0], &dir = c.outputs[1];
    std::vector<double> o_ref, d_ref, v_ref;
    for (const Camera& cam : cameras())
      for (size_t r = 0; r < R; ++r) {
        const RefRay ref = ref_ray(cam, pixels[2 * r], pixels[2 * r + 1], false, 1.0);
        o_ref.insert(o_ref.end(), ref.o.begin(), ref.o.end());
        d_ref.insert(d_ref.end(), ref.d.begin(), ref.d.end());
        v_ref.insert(v_ref.end(), ref.view.begin(), ref.view.end());
      }
    const auto z = ref_depths(R, S, 2.0, 6.0, c.values[2]);
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
    return std::vector<Expected>{{o_ref, {1e-6, 1e-6}}, {d_ref, {1e-6, 1e-6}}, {v_ref, {1e-6, 1e-6}}, {z, {6e-6, 1e-6}},
                                 {delta, {1e-6, 1e-4}}, {pos0, {6e-5, 1e-6}}, {pos1, {6e-5, 1e-6}}};
  };
  e.flops = [](const OpShape& s) { return double(s.dims[0]) * 3 * (40 + 12 * s.dims[1]); };
  return e;
}

// instance_points: points x 3 placed instances, NDC and metric, as test_rays
// (rays_reference.hpp states the tolerance: 1e-4 on NDC values in [-2, 2]; the check is
// op_table_checks.cpp's).
OpEntry instance_points_entry() {
  OpEntry e;
  e.name = "instance_points";
  e.shapes = {{{kOddRows}, 0, "1009 points x 3 instances"}, {{1}, 0, "1 point x 3 instances"}};
  e.build = [](Graph& g, const OpShape& s) {
    Tensor pos = g.input("positions", Shape{s.dims[0], 3}), tr = g.input("transforms", Shape{3, 12});
    return OpGraph{{pos, tr}, {instance_points(pos, tr)}, {}};
  };
  e.values = [](const OpShape& s) {
    return std::vector<std::vector<float>>{random_floats(s.dims[0] * 3, -0.5f, 0.5f, 163), random_floats(36, -1, 1, 164)};
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

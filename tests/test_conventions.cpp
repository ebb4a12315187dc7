// The reference code's loss conventions (LossConventions, novel_view_loss.hpp), item by item: each
// against a float64 host reference written from the public reference code's formula, with
// a finite-difference check of every changed differentiable op, and the presets selecting
// them (quick: nova's own, reference: the reference code's).
#include <boost/test/unit_test.hpp>
#include <cmath>
#include <set>
#include <sstream>

#include "harness.hpp"
#include "conventions_reference.hpp"
#include "loss_reference.hpp"
#include "nova/loss/terms.hpp"
#include "nova/loss/objective.hpp"
#include "nova/model/field_graphs.hpp"
#include "nova/render/render_composite.hpp"
#include "nova/train/step_graphs.hpp"
#include "nova/train/train_config.hpp"
#include "render_check.hpp"

using namespace nova;
using namespace nova::test;

namespace {

double device_scalar(Graph& g, Tensor y, const std::vector<std::pair<Tensor, std::vector<float>>>& in) {
  g.keep(y);
  Executor ex(runtime(), g);
  for (const auto& [t, v] : in) ex.set(t, v);
  ex.forward();
  return ex.get(y).at(0);
}

// Losses are float32 two-stage sums of at most a few thousand O(1) terms, then at most one
// division per NeRF: relative error about 1e-6 in practice; rtol 1e-5 with atol 1e-7 is
// tight enough to catch a wrong normalisation (a factor of N, R, S or 3) or a missed term.
constexpr double kAtol = 1e-7, kRtol = 1e-5;

// pred - target kept at least `gap` away from 0 (random sign): an L1 term then has no kink
// within the harness's finite-difference step (1e-2).
std::vector<float> apart_from(const std::vector<float>& base, float gap, unsigned seed) {
  const auto u = random_floats(base.size(), 0, 1, seed);
  std::vector<float> out(base.size());
  for (size_t i = 0; i < base.size(); ++i)
    out[i] = base[i] + (u[i] < 0.5f ? -1.0f : 1.0f) * (gap + 0.3f * u[i]);
  return out;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(conventions)

// 1. mask loss: L1 per NeRF (mean over rays), summed over NeRFs.
BOOST_AUTO_TEST_CASE(mask_l1_matches_reference) {
  const size_t N = 3, R = 37;
  const auto target = random_floats(N * R, 0, 1, 1);
  const auto pred = apart_from(target, 0.05f, 2);
  Graph g;
  Tensor p = g.input("mask", Shape{N, R}), t = g.input("target", Shape{N, R});
  const double v = device_scalar(g, mask_l1_loss(p, t), {{p, pred}, {t, target}});
  expect_close({float(v)}, {ref_mask_l1(pred, target, N, R)}, kAtol, kRtol, "mask_l1_loss");
  // Not nova's mse over N R: the two differ (so the switch is observable).
  double mse = 0;
  for (size_t e = 0; e < N * R; ++e) mse += (double(pred[e]) - target[e]) * (pred[e] - target[e]);
  BOOST_TEST(std::fabs(v - mse / double(N * R)) > 1e-3);
  // Harness FD check (default tolerance 2e-2 of the gradient scale, harness.hpp): the loss is
  // piecewise linear and no element is within the step of its kink, so central differences
  // are exact up to float32 rounding.
  check_gradients(
      [&](Graph& gg) {
        Tensor pp = gg.input("mask", Shape{N, R}, true), tt = gg.input("target", Shape{N, R});
        return OpUnderTest{{pp, tt}, mask_l1_loss(pp, tt)};
      },
      {pred, target});
}

// 2. per-NeRF RGB: each NeRF over its mask area, against its own target.
BOOST_AUTO_TEST_CASE(masked_mse_area_matches_reference) {
  const size_t G = 3, R = 41, K = 3;
  const auto pred = random_floats(G * R * K, 0, 1, 3), own = random_floats(G * R * K, 0, 1, 4);
  const auto shared = random_floats(R * K, 0, 1, 5);
  auto mask = random_floats(G * R, 0, 1, 6);
  for (float& m : mask) m = m < 0.4f ? 0.0f : m < 0.8f ? 1.0f : m;  // binary and soft
  for (size_t r = 0; r < R; ++r) mask[2 * R + r] = 0.0f;             // an empty group: adds 0
  for (const auto* target : {&own, &shared}) {
    const bool is_own = target == &own;
    const Shape ts = is_own ? Shape{G, R, K} : Shape{R, K};
    Graph g;
    Tensor p = g.input("pred", Shape{G, R, K}), t = g.input("target", ts), m = g.input("mask", Shape{G, R});
    const double v = device_scalar(g, masked_mse_area(p, t, m), {{p, pred}, {t, *target}, {m, mask}});
    expect_close({float(v)}, {ref_mse_area(pred, *target, mask, G, R, K)}, kAtol, kRtol,
                 is_own ? "masked_mse_area, own targets" : "masked_mse_area, shared target");
    // Quadratic in pred: FD exact up to rounding (harness default tolerance).
    check_gradients(
        [&](Graph& gg) {
          Tensor pp = gg.input("pred", Shape{G, R, K}, true), tt = gg.input("target", ts),
                 mm = gg.input("mask", Shape{G, R});
          return OpUnderTest{{pp, tt, mm}, masked_mse_area(pp, tt, mm)};
        },
        {pred, *target, mask});
  }
  // Each NeRF reads its own target: a change in group 1's target moves only its term.
  auto own2 = own;
  for (size_t e = R * K; e < 2 * R * K; ++e) own2[e] = 1.0f - own2[e];
  const double a = ref_mse_area(pred, own, mask, G, R, K), b = ref_mse_area(pred, own2, mask, G, R, K);
  Graph g;
  Tensor p = g.input("pred", Shape{G, R, K}), t = g.input("target", Shape{G, R, K}), m = g.input("mask", Shape{G, R});
  const double v = device_scalar(g, masked_mse_area(p, t, m), {{p, pred}, {t, own2}, {m, mask}});
  BOOST_TEST(std::fabs(a - b) > 1e-3);
  expect_close({float(v)}, {b}, kAtol, kRtol, "masked_mse_area reads each group's own target");
}

// 3. alpha loss: per object, means of blend and alpha over the rays with mask != 1.
BOOST_AUTO_TEST_CASE(alpha_loss_outside_matches_reference) {
  const size_t N = 3, R = 7, S = 9;
  const auto raw = smooth_raw(N, R * S, 7);  // sigma kept 0.1 away from the ReLU's kink
  for (bool per_nerf_delta : {false, true}) {
    const size_t dn = per_nerf_delta ? N * R * S : R * S;
    const auto delta = random_floats(dn, 0.05f, 0.5f, 8);
    const auto noise = random_floats(N * R * S, -0.05f, 0.05f, 9);
    auto masks = random_floats(N * R, 0, 1, 10);
    // 1 (inside), 0 (outside) and fractional (outside too: the reference tests m != 1).
    for (float& m : masks) m = m < 0.4f ? 0.0f : m < 0.8f ? 1.0f : 0.5f;
    const Shape ds = per_nerf_delta ? Shape{N, R, S} : Shape{R, S};
    Graph g;
    Tensor r = g.input("raw", Shape{N, R * S, 5}), d = g.input("delta", ds), m = g.input("masks", Shape{N, R}),
           z = g.input("noise", Shape{N, R * S});
    const double v = device_scalar(g, alpha_loss_outside(r, d, m, z),
                                   {{r, raw}, {d, delta}, {m, masks}, {z, noise}});
    expect_close({float(v)}, {ref_alpha_outside(raw, delta, masks, noise, N, R, S)}, kAtol, kRtol,
                 "alpha_loss_outside");
    // Smooth in raw away from the ReLU kink (|sigma| >= 0.1, noise 0.05, step 1e-2): FD with
    // the harness default tolerance.
    check_gradients(
        [&](Graph& gg) {
          Tensor rr = gg.input("raw", Shape{N, R * S, 5}, true), dd = gg.input("delta", ds),
                 mm = gg.input("masks", Shape{N, R}), zz = gg.input("noise", Shape{N, R * S});
          return OpUnderTest{{rr, dd, mm, zz}, alpha_loss_outside(rr, dd, mm, zz)};
        },
        {raw, delta, masks, noise});
  }
  // An object whose mask is 1 on every ray adds nothing (and no NaN).
  std::vector<float> masks(N * R, 1.0f);
  const auto delta = random_floats(R * S, 0.05f, 0.5f, 11);
  Graph g;
  Tensor r = g.input("raw", Shape{N, R * S, 5}), d = g.input("delta", Shape{R, S}), m = g.input("masks", Shape{N, R});
  const double v = device_scalar(g, alpha_loss_outside(r, d, m), {{r, raw}, {d, delta}, {m, masks}});
  BOOST_TEST(v == 0.0);
}

// 4. M_n with alpha_full = sum_n alpha_n b_n; 5. blend epsilon 1e-8; render_composite's
// forward against the float64 reference and its gradient against float64 central
// differences. Tolerances as tests/test_render.cpp (forward atol 2e-6, rtol 1e-5; gradient
// atol 1e-4 of the gradient scale, rtol 1e-3), for the same reasons: the variants change
// one sum per sample, not the error budget.
BOOST_AUTO_TEST_CASE(render_mask_sum_and_blend_eps_match_reference) {
  for (int nerfs : {2, 3}) {
    RenderRefInput in = random_render_case(nerfs, 3, 24, 5, nerfs == 3, true, 21 + nerfs);
    in.alpha_full_sum = true;
    in.blend_eps = 1e-8;
    // Some samples where every blend is about 1e-11 (raw -25): there the epsilon decides b_n.
    for (int r = 0; r < in.rays; ++r)
      for (int i = 0; i < in.samples; i += 5)
        for (int n = 0; n < nerfs; ++n) in.raw[((size_t(n) * in.rays + r) * in.samples + i) * 5 + 4] = -25.0;
    const RenderTargets t = random_targets(in, 31);
    const DeviceRender d = run_device_render(in, t);
    const std::string what = "mask sum, eps 1e-8, N=" + std::to_string(nerfs);
    expect_forward_close(d, in, 2e-6, 1e-5, what);
    expect_gradient_close(d, in, t, 1e-4, 1e-3, what);
    // Both switches are observable: nova's union differs in the mask, nova's 1e-6 in rgb.
    RenderRefInput nova = in;
    nova.alpha_full_sum = false;
    BOOST_TEST(max_scaled_error(d.mask, render_reference(nova).mask, 2e-6, 1e-5) > 10.0);
    nova = in;
    nova.blend_eps = 1e-6;
    BOOST_TEST(max_scaled_error(d.rgb, render_reference(nova).rgb, 2e-6, 1e-5) > 10.0);
  }
}

// 6. plain pretraining render: N = 1 without blending is the reference code's raw2outputs_d.
BOOST_AUTO_TEST_CASE(plain_render_matches_reference) {
  RenderRefInput in = random_render_case(1, 5, 32, 5, false, true, 41);
  in.no_blend = true;
  // A few small blends (raw -12: sigmoid 6e-6), where nova's b = blend / (blend + 1e-6) is
  // 0.86; elsewhere it is within 2e-5 of the plain render's 1.
  for (size_t e = 0; e < in.raw.size() / 5; e += 4) in.raw[e * 5 + 4] = -12.0;
  const RenderTargets t = random_targets(in, 42);
  const DeviceRender d = run_device_render(in, t);
  expect_forward_close(d, in, 2e-6, 1e-5, "plain render");
  expect_gradient_close(d, in, t, 1e-4, 1e-3, "plain render");
  // Independently of render_reference: the composite is the plain NeRF colour
  // sum_i T_i alpha_i c_i, T_i = prod_{j<i} (1 - alpha_j + 1e-10) (float64).
  std::vector<double> plain(in.rays * 3, 0.0);
  for (int r = 0; r < in.rays; ++r) {
    double T = 1;
    for (int i = 0; i < in.samples; ++i) {
      const size_t e = size_t(r) * in.samples + i;
      const double sigma = std::max(0.0, in.raw[e * 5 + 3] + in.noise[e]);
      const double a = 1.0 - std::exp(-sigma * in.delta[e]);
      for (int k = 0; k < 3; ++k) plain[r * 3 + k] += T * a * ref_sigmoid(in.raw[e * 5 + k]);
      T *= 1.0 - a + 1e-10;
    }
  }
  expect_close(d.rgb, plain, 2e-6, 1e-5, "plain render is raw2outputs_d");
  // The blend channel takes no part: exactly zero gradient.
  for (size_t e = 4; e < d.grad_raw.size(); e += 5) BOOST_TEST(d.grad_raw[e] == 0.0f);
  // With blending (nova's pretraining) each sample's alpha is scaled by b = blend / (blend + 1e-6).
  RenderRefInput blended = in;
  blended.no_blend = false;
  BOOST_TEST(max_scaled_error(d.rgb, render_reference(blended).rgb, 2e-6, 1e-5) > 10.0);
}

// 7. order loss: nerf_depth (each NeRF alone) from render_composite, then order_loss.
BOOST_AUTO_TEST_CASE(nerf_depth_matches_reference) {
  RenderRefInput in = random_render_case(3, 3, 20, 6, true, true, 51);
  in.nerf_depth = true;
  const RenderTargets t = random_targets(in, 52);
  const DeviceRender d = run_device_render(in, t);
  expect_forward_close(d, in, 2e-6, 1e-5, "nerf_depth");
  expect_gradient_close(d, in, t, 1e-4, 1e-3, "nerf_depth");
}

BOOST_AUTO_TEST_CASE(order_loss_matches_reference) {
  const size_t N = 3, R = 29;
  const auto d0 = random_floats(R, 0.2f, 0.8f, 61);
  std::vector<float> depth(N * R);
  for (size_t r = 0; r < R; ++r) depth[r] = d0[r];
  const auto rest = apart_from(std::vector<float>(d0.begin(), d0.end()), 0.05f, 62);
  const auto rest2 = apart_from(std::vector<float>(d0.begin(), d0.end()), 0.05f, 63);
  for (size_t r = 0; r < R; ++r) {
    depth[R + r] = rest[r];
    depth[2 * R + r] = rest2[r];
  }
  auto masks = random_floats(N * R, 0, 1, 64);
  for (float& m : masks) m = m < 0.4f ? 0.0f : m < 0.8f ? 1.0f : m;
  Graph g;
  Tensor dd = g.input("depth", Shape{N, R}), mm = g.input("masks", Shape{N, R});
  const double v = device_scalar(g, order_loss(dd, mm), {{dd, depth}, {mm, masks}});
  expect_close({float(v)}, {ref_order(depth, masks, N, R)}, 1e-9, kRtol, "order_loss");
  // Piecewise linear, every |d_n - d_0| >= 0.05 > the step 1e-2 (no kink crossed; the static
  // depth moves by the step too, so 0.05 leaves 0.03): harness default tolerance.
  check_gradients(
      [&](Graph& gg) {
        Tensor x = gg.input("depth", Shape{N, R}, true), m = gg.input("masks", Shape{N, R});
        return OpUnderTest{{x, m}, order_loss(x, m)};
      },
      {depth, masks});
}

// The presets: quick keeps nova's conventions, reference takes the reference code's; both
// round-trip through config.ini, and a run file written before the options existed keeps
// nova's (what it ran with), whatever its preset.
BOOST_AUTO_TEST_CASE(presets_select_their_conventions) {
  const TrainConfig q = preset_config("quick"), r = preset_config("reference");
  BOOST_TEST(!q.conventions.mask_l1);
  BOOST_TEST(!q.conventions.nerf_rgb_area);
  BOOST_TEST(!q.conventions.alpha_outside);
  BOOST_TEST(!q.conventions.mask_sum);
  BOOST_TEST(q.conventions.blend_eps == 1e-6f);
  BOOST_TEST(!q.conventions.pretrain_plain);
  BOOST_TEST(q.weights.order == 0.0f);
  BOOST_TEST(r.conventions.mask_l1);
  BOOST_TEST(r.conventions.nerf_rgb_area);
  BOOST_TEST(r.conventions.alpha_outside);
  BOOST_TEST(r.conventions.mask_sum);
  BOOST_TEST(r.conventions.blend_eps == 1e-8f);
  BOOST_TEST(r.conventions.pretrain_plain);
  BOOST_TEST(r.weights.order == 0.1f);

  for (const TrainConfig& c : {q, r}) {
    const TrainConfig back = parse_config_text(format_config(c), "config.ini", nullptr, ConfigFile::RunFile);
    BOOST_TEST(format_config(back) == format_config(c));
  }
  const std::string text = format_config(r);
  BOOST_TEST(text.find("mask-loss = l1") != std::string::npos);
  BOOST_TEST(text.find("nerf-rgb-loss = area") != std::string::npos);
  BOOST_TEST(text.find("alpha-loss = outside") != std::string::npos);
  BOOST_TEST(text.find("mask-render = sum") != std::string::npos);
  BOOST_TEST(text.find("blend-eps = 1e-08") != std::string::npos);
  BOOST_TEST(text.find("pretrain-render = plain") != std::string::npos);
  BOOST_TEST(text.find("w-order = 0.1") != std::string::npos);

  // An older reference run file: no convention keys at all.
  std::string old;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) {
    bool drop = false;
    for (const char* key : {"mask-loss", "nerf-rgb-loss", "alpha-loss", "mask-render", "blend-eps",
                            "pretrain-render", "w-order"})
      drop = drop || line.rfind(std::string(key) + " =", 0) == 0;
    if (!drop) old += line + "\n";
  }
  const TrainConfig o = parse_config_text(old, "config.ini", nullptr, ConfigFile::RunFile);
  BOOST_TEST(o.preset == "reference");
  BOOST_TEST(!o.conventions.mask_l1);
  BOOST_TEST(!o.conventions.nerf_rgb_area);
  BOOST_TEST(!o.conventions.alpha_outside);
  BOOST_TEST(!o.conventions.mask_sum);
  BOOST_TEST(o.conventions.blend_eps == 1e-6f);
  BOOST_TEST(!o.conventions.pretrain_plain);
  BOOST_TEST(o.weights.order == 0.0f);
  TrainConfig bad = q;
  BOOST_CHECK_THROW(set_config_value(bad, "mask-loss", "l2"), Error);
}

// The joint and pretraining graphs of each preset build the ops and render options of its
// conventions.
BOOST_AUTO_TEST_CASE(graphs_follow_the_conventions) {
  RayGeometry geo;
  geo.ndc = true;
  geo.num_objects = 2;
  geo.frames = 10;
  for (const std::string preset : {"quick", "reference"}) {
    TrainConfig c = preset_config(preset);
    c.field.depth = 2;
    c.field.width = 16;
    c.field.skip = -1;
    c.rays = 16;
    c.samples = 8;
    c.occupancy = false;
    const bool ref = preset == "reference";
    const auto joint = build_joint_graph(c, geo);
    std::multiset<std::string> types;
    for (size_t n = 0; n < joint->graph.node_count(); ++n) types.insert(joint->graph.node(n).type());
    BOOST_TEST(types.count("mask_l1") == (ref ? 1u : 0u), preset);
    BOOST_TEST(types.count("masked_mse_area") == (ref ? 1u : 0u), preset);
    BOOST_TEST(types.count("masked_mse") == (ref ? 0u : 1u), preset);
    BOOST_TEST(types.count("alpha_loss_outside") == (ref ? 1u : 0u), preset);
    BOOST_TEST(types.count("alpha_loss") == (ref ? 0u : 1u), preset);
    BOOST_TEST(types.count("order_loss") == (ref ? 1u : 0u), preset);
    BOOST_TEST(joint->target_nerf_rgb.valid() == ref, preset);
    const RenderOptions jo = joint_render_options(c.conventions, c.weights);
    BOOST_TEST(jo.alpha_full_sum == ref);
    BOOST_TEST(jo.nerf_depth == ref);
    BOOST_TEST(jo.blend_eps == (ref ? 1e-8f : 1e-6f));
    const RenderOptions po = pretrain_render_options(c.conventions);
    BOOST_TEST(po.no_blend == ref);
    // quick's render programs keep nova's options text exactly.
    if (!ref) {
      BOOST_TEST(render_program_options(3, jo) == render_program_options(3, RenderOptions{}));
      BOOST_TEST(render_program_options(1, po) == render_program_options(1, RenderOptions{}));
    } else {
      BOOST_TEST(render_program_options(3, jo).find("-DALPHA_FULL_SUM=1") != std::string::npos);
      BOOST_TEST(render_program_options(3, jo).find("-DBLEND_EPS=1e-08f") != std::string::npos);
      BOOST_TEST(render_program_options(1, po).find("-DNO_BLEND=1") != std::string::npos);
    }
  }
}

BOOST_AUTO_TEST_SUITE_END()

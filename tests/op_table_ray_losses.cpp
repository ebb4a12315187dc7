// The op table's losses along rays and of depths: depth_loss, sparsity_loss, distortion_loss
// and free_space_loss, over 1009 rays (several work-groups, a partial last one) and small
// cases.
#include <algorithm>
#include <cmath>
#include <string>

#include "distortion_reference.hpp"
#include "free_space_reference.hpp"
#include "loss_reference.hpp"
#include "nova/loss/terms.hpp"
#include "nova/render/render_composite.hpp"
#include "op_table.hpp"

namespace nova::test {

namespace {

// sparsity_loss: L1 on the object NeRFs' alpha inside their masks (the static NeRF n = 0 is
// exempt). A mean of values in [0, 1], each a few float32 roundings from its float64 value
// (expm1 within 4 ulp): rtol 1e-5. Gradients by central differences (harness default), sigma
// kept 0.05 from the ReLU kink the stencil would cross. dims: NeRFs N, rays R, samples S.
OpEntry sparsity_loss_entry() {
  OpEntry e;
  e.name = "sparsity_loss";
  OpShape odd{{2, kOddRows, 3}, 0, "2 NeRFs x 1009 rays x 3"};
  odd.no_fd = true;  // forward only: the stencil's cost grows with the rays
  e.shapes = {{{3, 7, 5}, 0, "3 NeRFs x 7 rays x 5"}, odd, {{2, 1, 1}, 0, "2 NeRFs x 1 ray x 1"}};
  e.build = [](Graph& g, const OpShape& s) {
    const size_t N = s.dims[0], R = s.dims[1], S = s.dims[2];
    Tensor raw = g.input("raw", Shape{N, R * S, size_t(kRawChannels)}, true);
    Tensor delta = g.input("delta", Shape{R, S}), masks = g.input("masks", Shape{N, R});
    Tensor l = sparsity_loss(raw, delta, masks);
    return OpGraph{{raw, delta, masks}, {l}, l};
  };
  e.values = [](const OpShape& s) {
    const size_t N = s.dims[0], R = s.dims[1], S = s.dims[2], C = kRawChannels;
    auto raw = random_floats(N * R * S * C, -2.0f, 2.0f, 1);
    for (size_t i = 0; i < N * R * S; ++i) {
      float& sigma = raw[i * C + kRawSigma];
      if (std::fabs(sigma) < 0.05f) sigma = 0.05f;
    }
    return std::vector<std::vector<float>>{raw, random_floats(R * S, 0.05f, 0.5f, 2), random_floats(N * R, 0.0f, 1.0f, 3)};
  };
  e.reference = [](const OpCase& c) {
    const size_t N = c.shape.dims[0], R = c.shape.dims[1], S = c.shape.dims[2], C = kRawChannels;
    const auto &raw = c.values[0], &delta = c.values[1], &masks = c.values[2];
    double ref = 0;
    for (size_t n = 1; n < N; ++n)
      for (size_t r = 0; r < R; ++r)
        for (size_t i = 0; i < S; ++i) {
          const double sigma = std::max(0.0, double(raw[((n * R + r) * S + i) * C + kRawSigma]));
          ref += masks[n * R + r] * -std::expm1(-sigma * delta[r * S + i]);
        }
    return std::vector<Expected>{{{ref / double((N - 1) * R * S)}, {0, 1e-5}}};
  };
  e.fd = GradCheckOptions{};
  e.flops = [](const OpShape& s) { return double(s.dims[0] * s.dims[1] * s.dims[2]) * 10; };
  return e;
}

OpEntry distortion_entry() {
  OpEntry e;
  e.name = "distortion_loss";
  // dims: NeRFs N, rays R, samples S; variant bits: 1 the object NeRFs alone (first NeRF 1,
  // as training uses it), 2 masks given, 4 noise given. Tolerances as
  // tests/test_distortion_loss_op.cpp: float32 prefix sums of weights <= 1, a few 2^-24 per
  // sample: atol 1e-6 plus rtol 1e-5; gradients by central differences at the harness
  // default (sigma + noise kept 0.05 from the ReLU kink).
  // Central differences with noise: without masks over every NeRF, with masks over the
  // object NeRFs (NeRF 0's gradient must then be 0), and at one ray.
  for (int v = 0; v < 8; ++v) {
    OpShape s{{3, 6, 9}, v, "3 NeRFs x 6 rays x 9, first " + std::to_string(v & 1) + (v & 2 ? ", masks" : "") +
                                (v & 4 ? ", noise" : "")};
    s.no_fd = v != 4 && v != 7;
    e.shapes.push_back(s);
  }
  OpShape odd{{2, kOddRows, 5}, 6, "2 NeRFs x 1009 rays x 5, masks, noise"};
  odd.no_fd = true;
  e.shapes.push_back(odd);
  e.shapes.push_back({{2, 1, 3}, 6, "2 NeRFs x 1 ray x 3, masks, noise"});
  e.build = [](Graph& g, const OpShape& s) {
    const size_t N = s.dims[0], R = s.dims[1], S = s.dims[2];
    Tensor raw = g.input("raw", Shape{N, R * S, size_t(kRawChannels)}, true);
    Tensor delta = g.input("delta", Shape{N, R, S}), z = g.input("z", Shape{R, S});
    Tensor m = g.input("masks", Shape{N, R}), nz = g.input("noise", Shape{N, R * S});
    Tensor l = distortion_loss(raw, delta, z, s.variant & 2 ? m : Tensor{}, s.variant & 4 ? nz : Tensor{},
                               static_cast<size_t>(s.variant & 1));
    return OpGraph{{raw, delta, z, m, nz}, {l}, l};
  };
  e.values = [](const OpShape& s) {
    const DistortionInputs in = distortion_inputs(s.dims[0], s.dims[1], s.dims[2], 11);
    return std::vector<std::vector<float>>{in.raw, in.delta, in.z, in.masks, in.noise};
  };
  e.reference = [](const OpCase& c) {
    DistortionInputs in{c.shape.dims[0], c.shape.dims[1], c.shape.dims[2], c.values[0], c.values[1], c.values[2],
                        c.values[3], c.values[4]};
    const int v = c.shape.variant;
    return std::vector<Expected>{{{distortion_reference(in, v & 2, v & 4, static_cast<size_t>(v & 1))}, {1e-6, 1e-5}}};
  };
  e.fd = GradCheckOptions{};
  e.flops = [](const OpShape& s) { return double(s.dims[0] * s.dims[1] * s.dims[2]) * 40; };
  return e;
}

// free_space_loss against the float64 reference and its central differences in sigma
// (op_table_checks.cpp): the loss rtol 1e-4 (it sums at most N R S float32 products of O(1)
// values), its gradient rtol 1e-3 with atol 1e-5 of the gradient's scale (truncation O(h^2)
// and float32 chains of S terms). Variant 0: 2 NeRFs x 1009 rays x 3, the table's case
// (free_space_table_case, step 1e-3); 1-3: 3 NeRFs x 37 rays x 11 of the op's own cases
// (free_space_random_case, step 1e-4 on sigmas kept 0.3 from the ReLU kink), plain, with
// density noise, with weight behind the surface (behind 0.7), and with the surface given (no
// fit: targets in [0.2, 0.9], inside the samples' span, so both sides of it are exercised).
OpEntry free_space_entry() {
  OpEntry e;
  e.name = "free_space_loss";
  e.shapes = {{{2, kOddRows, 3}, 0, "2 NeRFs x 1009 rays x 3"},
              {{3, 37, 11}, 1, "3 NeRFs x 37 rays x 11"},
              {{3, 37, 11}, 2, "3 NeRFs x 37 rays x 11, noise"},
              {{3, 37, 11}, 3, "3 NeRFs x 37 rays x 11, behind 0.7"},
              {{3, 37, 11}, 4, "3 NeRFs x 37 rays x 11, surface given"}};
  e.build = [](Graph& g, const OpShape& s) { return free_space_graph(g, s, nullptr); };
  e.values = free_space_values;
  e.flops = [](const OpShape& s) { return double(s.dims[0] * s.dims[1] * s.dims[2]) * 40; };
  return e;
}

}  // namespace

FreeSpaceCase free_space_case(const OpShape& s) {
  if (s.variant == 0) return free_space_table_case(s.dims[0], s.dims[1], s.dims[2]);
  FreeSpaceCase f = free_space_random_case(s.dims[0], s.dims[1], s.dims[2], s.variant == 2, 10 * unsigned(s.variant));
  f.behind = s.variant == 3 ? 0.7f : 0.0f;
  if (s.variant == 4) {
    f.fitted = false;
    f.target = random_floats(f.R, 0.2f, 0.9f, 44);
  }
  return f;
}

std::vector<std::vector<float>> free_space_values(const OpShape& s) {
  const FreeSpaceCase f = free_space_case(s);
  std::vector<std::vector<float>> v = {f.raw, f.delta, f.z, f.depth, f.target, f.valid, f.masks};
  if (!f.noise.empty()) v.push_back(f.noise);
  return v;
}

OpGraph free_space_graph(Graph& g, const OpShape& s, GradientReducer* ranks) {
  const FreeSpaceCase f = free_space_case(s);
  const size_t N = f.N, R = f.R, S = f.S;
  Tensor raw = g.input("raw", Shape{N, R * S, 5}, true), delta = g.input("delta", Shape{N, R, S});
  Tensor z = g.input("z", Shape{R, S}), depth = g.input("depth", Shape{R}), target = g.input("target", Shape{R});
  Tensor valid = g.input("valid", Shape{R}), masks = g.input("masks", Shape{N, R});
  Tensor noise = f.noise.empty() ? Tensor{} : g.input("noise", Shape{N, R * S});
  Tensor l = free_space_loss(raw, delta, z, depth, target, valid, masks, noise, f.margin, 1, f.behind, ranks, f.fitted);
  std::vector<Tensor> inputs = {raw, delta, z, depth, target, valid, masks};
  if (noise.valid()) inputs.push_back(noise);
  return OpGraph{inputs, {l}, l};
}

// depth_loss: every fifth ray invalid; its float64 definition and the central differences of
// it (loss_reference.hpp). With `ranks`, the loss built from moments summed over ranks.
OpEntry depth_loss_entry(GradientReducer* ranks) {
  OpEntry e;
  e.name = ranks ? "depth_loss_over_ranks" : "depth_loss";
  // The central differences of the device forward (harness default: the loss is smooth away
  // from zero variance, and the random depths keep the variance O(0.1)) up to 64 rays.
  e.shapes = {{{kOddRows}, 0, "1009 rays"}, {{57}, 0, "57 rays"}, {{23}, 0, "23 rays"}, {{7}, 0, "7 rays"}};
  e.build = [ranks](Graph& g, const OpShape& s) {
    const Shape sh{s.dims[0]};
    Tensor p = g.input("depth", sh, true), t = g.input("target", sh), w = g.input("valid", sh);
    Tensor l = depth_loss(p, t, w, ranks);
    return OpGraph{{p, t, w}, {l}, l};
  };
  e.values = [](const OpShape& s) {
    std::vector<float> w(s.dims[0], 1.0f);
    for (size_t i = 0; i < w.size(); i += 5) w[i] = 0.0f;
    return std::vector<std::vector<float>>{random_floats(s.dims[0], 0.0f, 1.0f, 181), random_floats(s.dims[0], -2.0f, 3.0f, 182), w};
  };
  // Float32 sums over the rays (one kernel, or the moments summed over ranks; a relative error
  // of a few 1e-6 at 1009 rays) and a loss near 2 for uncorrelated depths: rtol 1e-4.
  e.reference = [](const OpCase& c) {
    return std::vector<Expected>{{{ref_depth_loss(to_double(c.values[0]), c.values[1], c.values[2])}, {0, 1e-4}}};
  };
  e.gradient = [](const OpCase& c) {
    const std::vector<double> fd = ref_depth_loss_gradient(to_double(c.values[0]), c.values[1], c.values[2]);
    // The gradient carries the cancellations of the standardisation: rtol 1e-3 and atol 1e-4
    // of the gradient's scale.
    return std::vector<Expected>{{fd, {1e-4 * max_abs(fd), 1e-3}}, {}, {}};
  };
  e.fd = GradCheckOptions{};
  // Two passes of ~6 operations a ray forward and ~10 backward; the scalar kernels are O(1).
  e.flops = [](const OpShape& s) { return double(s.dims[0]) * 32; };
  return e;
}

void register_ray_loss_ops(std::vector<OpEntry>& t) {
  t.push_back(depth_loss_entry());
  t.push_back(sparsity_loss_entry());
  t.push_back(distortion_entry());
  t.push_back(free_space_entry());
}

}  // namespace nova::test

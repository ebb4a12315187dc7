// The op table's motion ops: rigid_motion and motion_smoothness (motion.hpp), the warp that
// crowds a step's samples into the moved objects' boxes (sample_warp.hpp), and the hash
// encoding's gradient to its positions, which carries a moved object's loss to its motion.
#include <cmath>
#include <cstdlib>

#include "hashgrid_reference.hpp"
#include "nova/ops/encoding/hash_encoding.hpp"
#include "nova/model/object_samples.hpp"
#include "nova/sampling/rigid_motion.hpp"
#include "nova/sampling/sample_warp.hpp"
#include "op_table.hpp"

namespace nova::test {
namespace {

// dims: networks B, rows M, frames F; variant 0 metric, 1 NDC.
MotionOptions motion_case_options(const OpShape& s) {
  MotionOptions o;
  o.frames = static_cast<int>(s.dims[2]);
  o.ndc = s.variant == 1;
  o.ax = -1.7f;
  o.ay = -1.3f;
  return o;
}

// Positions in the NDC box (z in [-1, 0.6]: world depths 1 to 5) or a metric cube; times
// anywhere on [-1, 1], frames' own times included; angles up to 0.6 rad; translations about
// world z = -3, so that the pivot (their mean) keeps NDC samples in front of the camera.
std::vector<std::vector<float>> motion_case_values(const OpShape& s) {
  const size_t B = s.dims[0], M = s.dims[1], F = s.dims[2];
  std::vector<float> p = random_floats(B * M * 3, -1.0f, 1.0f, 301);
  if (s.variant == 1)
    for (size_t i = 2; i < p.size(); i += 3) p[i] = -1.0f + 0.8f * (p[i] + 1.0f);
  std::vector<float> t = random_floats(B, -1.0f, 1.0f, 302);
  if (B > 1) t[1] = 2.0f * 1.0f / static_cast<float>(F) - 1.0f;  // exactly frame 1's time
  std::vector<float> m(F * 6 * B);
  const std::vector<float> r = random_floats(m.size(), -1.0f, 1.0f, 303);
  for (size_t i = 0; i < m.size(); ++i) {
    const size_t j = i % 6;
    m[i] = j < 3 ? 0.6f * r[i] : (j == 5 ? -3.0f : 0.0f) + 0.4f * r[i];
  }
  return {p, t, m};
}

// The op's forward in float64: world (from NDC), moved, back to NDC.
std::vector<double> motion_forward(const OpShape& s, const std::vector<float>& p, const std::vector<float>& t,
                                   const std::vector<float>& m) {
  const MotionOptions o = motion_case_options(s);
  const size_t B = s.dims[0], M = s.dims[1], F = s.dims[2];
  std::vector<double> out(B * M * 3);
  for (size_t b = 0; b < B; ++b)
    for (size_t r = 0; r < M; ++r) {
      const float* q = &p[(b * M + r) * 3];
      Vec3 x{q[0], q[1], q[2]};
      if (o.ndc) {
        const double z = 2.0 * o.ndc_near / std::min(q[2] - 1.0, -1e-6);
        x = {q[0] * z / o.ax, q[1] * z / o.ay, z};
      }
      Vec3 y = motion_to_canonical(&m[b * F * 6], o.frames, t[b], x);
      if (o.ndc) {
        const double z = std::min(y[2], -1e-6);
        y = {o.ax * y[0] / z, o.ay * y[1] / z, 1.0 + 2.0 * o.ndc_near / z};
      }
      for (size_t k = 0; k < 3; ++k) out[(b * M + r) * 3 + k] = y[k];
    }
  return out;
}

OpEntry rigid_motion_entry() {
  OpEntry e;
  e.name = "rigid_motion";
  e.shapes = {{{1, kOddRows, 5}, 0, "1009 rows, 5 frames, metric"}, {{1, kOddRows, 5}, 1, "1009 rows, 5 frames, NDC"},
              {{3, 17, 7}, 1, "3 x 17 rows, 7 frames, NDC"}, {{2, 1, 1}, 0, "2 x 1 row, 1 frame"},
              {{2, 13, 2}, 1, "2 x 13 rows, 2 frames, NDC"}};
  e.build = [](Graph& g, const OpShape& s) {
    const size_t B = s.dims[0], M = s.dims[1], F = s.dims[2];
    Tensor p = g.input("p", B > 1 ? Shape{B, M, 3} : Shape{M, 3});
    Tensor t = g.input("t", Shape{B, 1});
    Tensor m = g.input("motion", B > 1 ? Shape{B, F, 6} : Shape{F, 6}, true);
    return OpGraph{{p, t, m}, {rigid_motion(p, t, m, motion_case_options(s))}, {}};
  };
  e.values = motion_case_values;
  // Float32 rounding of the rotation (a few ulp per entry), of the world point (NDC z up to
  // 0.6: world depth 5, ulp 5e-7) and of the map back to NDC (a quotient): a few 1e-6 of
  // coordinates of magnitude <= 2; a wrong angle, frame weight or pivot is off by O(0.01).
  e.reference = [](const OpCase& c) {
    return std::vector<Expected>{{motion_forward(c.shape, c.values[0], c.values[1], c.values[2]), {2e-5, 2e-5}}};
  };
  // The float64 gradient by central differences of the float64 forward (the map is smooth
  // in the motion: h = 1e-6 leaves an O(h^2) error of about 1e-12), applied to the device's
  // upstream gradient.
  e.gradient = [](const OpCase& c) {
    std::vector<float> m = c.values[2];
    std::vector<double> d(m.size(), 0.0);
    for (size_t i = 0; i < m.size(); ++i) {
      const float v = m[i];
      const double h = 1e-3;
      double dot[2], step[2];
      for (int side = 0; side < 2; ++side) {
        m[i] = static_cast<float>(v + (side == 0 ? h : -h));
        step[side] = static_cast<double>(m[i]);  // the float the forward reads
        const std::vector<double> y = motion_forward(c.shape, c.values[0], c.values[1], m);
        dot[side] = 0;
        for (size_t k = 0; k < y.size(); ++k) dot[side] += c.upstream[0][k] * y[k];
      }
      const double sum = (dot[0] - dot[1]) / (step[0] - step[1]);
      m[i] = v;
      d[i] = sum;
    }
    // Central differences of step 1e-3 on a smooth map of curvature O(1): truncation
    // O(h^2) = 1e-6 of the gradient's scale, beside float32 rounding of the device's sums
    // over up to 1009 rows (1e-5 relative).
    Expected x = grad_expected(d);
    x.tol.atol = 1e-4 * max_abs(d) + 1e-7;
    x.tol.rtol = 1e-4;
    return std::vector<Expected>{{}, {}, x};
  };
  e.fd = GradCheckOptions{1e-3f};
  e.fd_max_rows = 3;
  e.flops = [](const OpShape& s) { return double(s.dims[0] * s.dims[1]) * 400; };
  return e;
}

OpEntry motion_smoothness_entry() {
  OpEntry e;
  e.name = "motion_smoothness";
  // dims: networks B, frames F.
  e.shapes = {{{1, 9}, 0, "9 frames"}, {{3, 4}, 0, "3 x 4 frames"}, {{2, 2}, 0, "2 x 2 frames (no term)"}};
  e.build = [](Graph& g, const OpShape& s) {
    const size_t B = s.dims[0], F = s.dims[1];
    Tensor m = g.input("motion", B > 1 ? Shape{B, F, 6} : Shape{F, 6}, true);
    Tensor l = motion_smoothness(m, static_cast<int>(F));
    return OpGraph{{m}, {l}, l};
  };
  e.values = [](const OpShape& s) {
    return std::vector<std::vector<float>>{random_floats(s.dims[0] * s.dims[1] * 6, -1, 1, 311)};
  };
  const auto compute = [](const OpCase& c, bool grad) {
    const size_t B = c.shape.dims[0], F = c.shape.dims[1];
    const auto& m = c.values[0];
    double loss = 0;
    std::vector<double> d(m.size(), 0.0);
    if (F > 2) {
      const double n = static_cast<double>(B * (F - 2));
      for (size_t b = 0; b < B; ++b)
        for (size_t f = 1; f + 1 < F; ++f)
          for (size_t j = 0; j < 6; ++j) {
            auto at = [&](size_t g) { return (b * F + g) * 6 + j; };
            const double s = double(m[at(f - 1)]) - 2.0 * m[at(f)] + m[at(f + 1)];
            loss += s * s / n;
            d[at(f - 1)] += 2 * s / n;
            d[at(f)] -= 4 * s / n;
            d[at(f + 1)] += 2 * s / n;
          }
    }
    return grad ? d : std::vector<double>{loss};
  };
  // A float32 sum of at most 6 B F squares: 1e-6 relative.
  e.reference = [=](const OpCase& c) { return std::vector<Expected>{{compute(c, false), {1e-6, 1e-5}}}; };
  e.gradient = [=](const OpCase& c) { return std::vector<Expected>{grad_expected(compute(c, true))}; };
  e.fd = GradCheckOptions{1e-2f};  // a quadratic: central differences are exact but for rounding
  e.flops = [](const OpShape& s) { return double(s.dims[0] * s.dims[1]) * 6 * 12; };
  return e;
}

// dims: rows, D, networks; coarse grids (2 levels of 2 to 5 cells, dense; 2^6 entries) so
// that the stencil of the central differences rarely crosses a cell face, where the encoding
// has no derivative; variant 1 a hashed fine level (2 levels of 3 to 24 cells on 2^6 entries).
HashGridConfig position_grid(const OpShape& s) {
  HashGridConfig c = s.variant == 0 ? grid_config(2, 2, 6, 2, 5) : grid_config(2, 3, 6, 3, 24);
  c.bound = 1.0f;
  if (s.dims[1] == 4) c.time_max_resolution = 2;
  return c;
}

OpEntry hash_positions_entry() {
  OpEntry e;
  e.name = "hash_encoding_positions";
  OpShape tiny{{5, 3, 1}, 0, "5 x 3, coarse, h 1e-4"};
  tiny.fd = GradCheckOptions{1e-4f, 48, 5e-2};
  // dims[3] = 1: the one-row-per-item kernel that goes with the atomic table backward (GPUs);
  // otherwise the level-by-level pass and its sum (CPUs).
  e.shapes = {{{kOddRows, 3, 1}, 0, "1009 x 3, coarse"}, {{kOddRows, 3, 2}, 1, "2 x 1009 x 3, hashed"},
              {{23, 4, 1}, 1, "23 x 4 (xyzt), hashed"}, {{1, 3, 1}, 0, "1 x 3"}, tiny,
              {{kOddRows, 3, 2, 1}, 1, "2 x 1009 x 3, hashed, per row"},
              {{23, 4, 1, 1}, 1, "23 x 4 (xyzt), hashed, per row"}};
  // The path follows NOVA_HASH_BACKWARD, read when the executor is built and when it runs.
  e.prepare = [](const OpShape& s, const Runtime& rt) -> std::string {
    const bool per_row = s.dims.size() > 3 && s.dims[3] == 1;
    if (per_row && !rt.info().int64_atomics) return "the device has no cl_khr_int64_base_atomics";
    setenv("NOVA_HASH_BACKWARD", per_row ? "atomic" : "ordered", 1);
    return "";
  };
  e.restore = [] { unsetenv("NOVA_HASH_BACKWARD"); };
  e.build = [](Graph& g, const OpShape& s) {
    const size_t rows = s.dims[0], dims = s.dims[1], nets = s.dims[2];
    Tensor p = g.input("p", nets > 1 ? Shape{nets, rows, dims} : Shape{rows, dims}, true);
    Tensor t = g.input("table", hash_grid_table_shape(position_grid(s), nets));
    return OpGraph{{p, t}, {hash_encoding(p, t, position_grid(s))}, {}};
  };
  e.values = [](const OpShape& s) {
    const size_t rows = s.dims[0], dims = s.dims[1], nets = s.dims[2];
    // Inside the box (outside it a clamped coordinate has no derivative; test_hashgrid checks
    // the clamp), and times inside [-1, 1].
    return std::vector<std::vector<float>>{random_floats(nets * rows * dims, -0.95f, 0.95f, 321),
                                           random_floats(hash_grid_table_shape(position_grid(s), nets).numel(), -1, 1, 322)};
  };
  e.reference = [](const OpCase& c) {
    const size_t rows = c.shape.dims[0], dims = c.shape.dims[1], nets = c.shape.dims[2];
    const HashGridConfig hc = position_grid(c.shape);
    const std::vector<double> ref = hash_reference(c.values[0], c.values[1], rows, dims, nets, hc);
    // The forward's tolerance as hash_encoding's entry derives it (op_table_grid.cpp).
    return std::vector<Expected>{{ref, {dims * 2.0 * 4.0 * hc.max_resolution * std::ldexp(1.0, -24) + 2e-6, 1e-6}}};
  };
  // The float64 derivative: per level and vertex, the product of the other dimensions'
  // weights signed by the vertex's side, times cells per unit (res / (2 bound)), dotted with
  // the upstream gradient and the vertex's features.
  e.gradient = [](const OpCase& c) {
    const size_t rows = c.shape.dims[0], dims = c.shape.dims[1], nets = c.shape.dims[2];
    const HashGridConfig hc = position_grid(c.shape);
    const std::vector<float> res = hash_grid_resolutions(hc), res_t = hash_grid_time_resolutions(hc);
    const size_t tsize = hash_grid_table_shape(hc).numel(), outs = static_cast<size_t>(hc.outputs());
    const uint64_t T = uint64_t{1} << hc.log2_size;
    std::vector<double> d(c.values[0].size(), 0.0), magnitude(d.size(), 0.0);
    for (size_t b = 0; b < nets; ++b) {
      const std::vector<float> pb(c.values[0].begin() + b * rows * dims, c.values[0].begin() + (b + 1) * rows * dims);
      // For each dimension, the encoding's derivative by differencing the weights of the two
      // sides exactly: d/dx of a D-linear weight is the weight with frac replaced by +-1.
      for (size_t r = 0; r < rows; ++r)
        for (size_t dim = 0; dim < dims; ++dim) {
          const std::vector<float> one(pb.begin() + r * dims, pb.begin() + (r + 1) * dims);
          for_each_vertex_derivative(one, dims, dim, hc, [&](int l, uint64_t row, double dw) {
            const double scale = 0.5 * (dim == 3 ? res_t[l] : res[l]) / (dim == 3 ? 1.0 : hc.half_size(static_cast<int>(dim)));
            for (int f = 0; f < hc.features; ++f) {
              const double term = dw * scale * c.values[1][b * tsize + (l * T + row) * hc.features + f] *
                                  c.upstream[0][(b * rows + r) * outs + (l * hc.features + f)];
              d[(b * rows + r) * dims + dim] += term;
              magnitude[(b * rows + r) * dims + dim] += std::fabs(term);
            }
          });
        }
    }
    // The kernel sums L 2^D F signed terms in float32, and its cell fractions carry a few
    // ulp of the grid coordinate (up to 24 cells: 24 2^-24 per fraction, which moves the
    // other dimensions' weights by as much): 1e-5 of the largest sum of |terms| bounds both
    //; a wrong sign, side or scale is off by O(1) of it.
    Expected x = grad_expected(d);
    x.tol.atol = 1e-5 * max_abs(magnitude);
    return std::vector<Expected>{x, {}};
  };
  e.fd = GradCheckOptions{1e-4f, 48, 5e-2};
  e.fd_max_rows = 5;
  e.flops = [](const OpShape& s) { return double(s.dims[0] * s.dims[2]) * 2 * double(1u << s.dims[1]) * 20; };
  return e;
}


// object_sample_warp: dims objects K, frames F; variant 1 puts object 0 across the near plane
// (its range clipped at t = 0) and object 1 wholly in front of it (no range: its share goes
// back to the even spread). Motions as motion_case_values (about world z = -3), radii
// 0.05-0.3 world units.
MotionOptions warp_case_options(const OpShape& s) {
  MotionOptions o;
  o.frames = static_cast<int>(s.dims[1]);
  o.ndc = true;
  o.ax = -1.7f;
  o.ay = -1.3f;
  return o;
}

constexpr double kWarpShare = 0.4;  // object_samples 4 of samples 10

OpEntry object_sample_warp_entry() {
  OpEntry e;
  e.name = "object_sample_warp";
  e.shapes = {{{1, 5}, 0, "1 object x 5 frames"}, {{3, 7}, 0, "3 objects x 7 frames"},
              {{2, 4}, 1, "2 objects x 4 frames, at and before the near plane"}};
  e.build = [](Graph& g, const OpShape& s) {
    const size_t K = s.dims[0], F = s.dims[1];
    Tensor m = g.input("motion", K > 1 ? Shape{K, F, 6} : Shape{F, 6});
    Tensor r = g.input("radius", Shape{K});
    Tensor t = g.input("times", Shape{K, 1});
    return OpGraph{{m, r, t}, {object_sample_warp(m, r, t, warp_case_options(s), kWarpShare, kObjectSampleRadii)}, {}};
  };
  e.values = [](const OpShape& s) {
    const size_t K = s.dims[0], F = s.dims[1];
    std::vector<float> m(K * F * 6);
    const std::vector<float> r = random_floats(m.size(), -1.0f, 1.0f, 331);
    for (size_t i = 0; i < m.size(); ++i) {
      const size_t j = i % 6;
      m[i] = j < 3 ? 0.6f * r[i] : (j == 5 ? -3.0f : 0.0f) + 0.4f * r[i];
    }
    if (s.variant == 1)
      for (size_t f = 0; f < F; ++f) {
        m[f * 6 + 5] = -1.2f + 0.01f * static_cast<float>(f);  // object 0 about the near plane
        m[(F + f) * 6 + 5] = -0.2f;                             // object 1 in front of it
      }
    return std::vector<std::vector<float>>{m, random_floats(K, 0.05f, 0.3f, 332), random_floats(K, -1.0f, 1.0f, 333)};
  };
  // The host's double path: motion_matrix and its pivot put the centre, depth_interval and
  // sample_warp (which rounds its knots to float) make the warp. The kernel's t = 1 + 1 / z
  // and cumulative sums are float32, a few ulp of values in [0, 1] each; 2e-5 leaves a factor
  // of ten.
  e.reference = [](const OpCase& c) {
    const size_t K = c.shape.dims[0], F = c.shape.dims[1];
    std::vector<Vec3> centres;
    std::vector<double> radii;
    for (size_t k = 0; k < K; ++k) {
      const float* rows = c.values[0].data() + k * F * 6;
      const Mat34 to_canonical = motion_matrix(rows, static_cast<int>(F), c.values[2][k]);
      centres.push_back(apply_rigid(invert_rigid(to_canonical), motion_pivot(rows, static_cast<int>(F))));
      radii.push_back(c.values[1][k]);
    }
    ModelConfig mc;
    mc.samples = 10;
    mc.object_samples = 4;  // the share 0.4
    const std::vector<float> w = object_sample_warp(mc, centres, radii);
    return std::vector<Expected>{{std::vector<double>(w.begin(), w.end()), {2e-5, 0}}};
  };
  e.flops = [](const OpShape& s) { return double(s.dims[0]) * 40 + double(s.dims[0] * s.dims[0]) * 8; };
  return e;
}

}  // namespace

void register_motion_ops(std::vector<OpEntry>& t) {
  t.push_back(object_sample_warp_entry());
  t.push_back(rigid_motion_entry());
  t.push_back(motion_smoothness_entry());
  t.push_back(hash_positions_entry());
}

}  // namespace nova::test

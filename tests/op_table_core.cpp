// The op table's tensor and layer ops: positional_encoding, bias_act, linear, dense, concat,
// gradient_gate, repeat_rows, scale_columns, bounded_offset, box_coordinates and the random draws. The 1009-row shapes are the odd-size sweep
// (several work-groups and a partial last one); the 1-row ones a single, partial group.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <memory>

#include "op_table.hpp"
#include "nova/ops/linalg/dense.hpp"
#include "nova/ops/tensor/tensor_ops.hpp"
#include "nova/ops/encoding/positional_encoding.hpp"
#include "nova/loss/terms.hpp"
#include "nova/sampling/random.hpp"
#include "random_reference.hpp"

namespace nova::test {

namespace {

constexpr Activation kActivations[4] = {Activation::Identity, Activation::ReLU, Activation::Sigmoid,
                                        Activation::Softplus};

double act_slope(Activation a, double x) {
  switch (a) {
    case Activation::ReLU: return x > 0 ? 1 : 0;
    case Activation::Sigmoid: {
      const double s = 1 / (1 + std::exp(-x));
      return s * (1 - s);
    }
    case Activation::Softplus: return 1 / (1 + std::exp(-x));
    default: return 1;
  }
}

// x [M, K] (or [B, M, K]) times w [K, N] (or [B, K, N]) in float64.
std::vector<double> matmul(const std::vector<float>& x, const std::vector<float>& w, size_t B, size_t M,
                           size_t K, size_t N) {
  std::vector<double> y(B * M * N, 0.0);
  for (size_t b = 0; b < B; ++b)
    for (size_t m = 0; m < M; ++m)
      for (size_t n = 0; n < N; ++n) {
        double s = 0;
        for (size_t k = 0; k < K; ++k) s += double(x[(b * M + m) * K + k]) * w[(b * K + k) * N + n];
        y[(b * M + m) * N + n] = s;
      }
  return y;
}

Shape batched(size_t B, size_t rows, size_t cols) { return B > 1 ? Shape{B, rows, cols} : Shape{rows, cols}; }

OpEntry positional_encoding_entry() {
  OpEntry e;
  e.name = "positional_encoding";
  // dims: rows, D, frequencies L.
  // L = 10 reaches sin(512 x), which a stencil of 1e-2 cannot resolve: no central
  // differences there. At L = 4 the highest band, sin(8 x), keeps the O(h^2 8^3) truncation
  // error small at h = 1e-3.
  OpShape wide{{37, 3, 10}, 0, "37 x 3, L 10"};
  wide.no_fd = true;
  OpShape fine{{11, 3, 4}, 0, "11 x 3, L 4, h 1e-3"};
  fine.fd = GradCheckOptions{1e-3f};
  e.shapes = {{{kOddRows, 3, 4}, 0, "1009 x 3, L 4"}, {{1, 3, 4}, 0, "1 x 3, L 4"}, {{37, 5, 2}, 0, "37 x 5, L 2"}, wide, fine};
  e.build = [](Graph& g, const OpShape& s) {
    Tensor p = g.input("p", Shape{s.dims[0], s.dims[1]}, true);
    return OpGraph{{p}, {positional_encoding(p, static_cast<int>(s.dims[2]))}, {}};
  };
  e.values = [](const OpShape& s) { return std::vector<std::vector<float>>{random_floats(s.dims[0] * s.dims[1], -1.5f, 1.5f, 101)}; };
  const auto compute = [](const OpCase& c, bool grad) {
    const size_t rows = c.shape.dims[0], dims = c.shape.dims[1];
    const int L = static_cast<int>(c.shape.dims[2]);
    const size_t width = dims * (1 + 2 * L);
    const auto& p = c.values[0];
    std::vector<double> ref(rows * width), dref(p.size());
    for (size_t r = 0; r < rows; ++r)
      for (size_t d = 0; d < dims; ++d) {
        const double v = p[r * dims + d];
        ref[r * width + d] = v;
        double g = grad ? c.upstream[0][r * width + d] : 0;
        for (int k = 0; k < L; ++k) {
          const double f = std::ldexp(1.0, k);
          const size_t sn = r * width + dims * (1 + 2 * k) + d, cs = sn + dims;
          ref[sn] = std::sin(f * v);
          ref[cs] = std::cos(f * v);
          if (grad) g += f * (std::cos(f * v) * c.upstream[0][sn] - std::sin(f * v) * c.upstream[0][cs]);
        }
        dref[r * dims + d] = g;
      }
    return grad ? dref : ref;
  };
  // sin/cos of arguments up to 768: <= 4 ulp of a value <= 1, so atol 1e-6.
  e.reference = [=](const OpCase& c) { return std::vector<Expected>{{compute(c, false), {1e-6, 1e-6}}}; };
  e.gradient = [=](const OpCase& c) { return std::vector<Expected>{grad_expected(compute(c, true))}; };
  e.fd = GradCheckOptions{};
  e.flops = [](const OpShape& s) { return double(s.dims[0] * s.dims[1] * s.dims[2]) * 2 * 20; };  // sin + cos, both passes
  return e;
}

OpEntry bias_act_entry() {
  OpEntry e;
  e.name = "bias_act";
  // dims: rows, cols, batch; variant: the activation. Every activation with one and three
  // networks at 1009 rows; 1-row and 37-row cases for the finite differences.
  for (int a = 0; a < 4; ++a)
    for (size_t batch : {size_t{1}, size_t{3}})
      e.shapes.push_back({{kOddRows, 7, batch}, a, std::string(activation_name(kActivations[a])) + ", 1009 x 7 x " + std::to_string(batch)});
  // Every activation at 29 x 17 (one and three networks; forward and float64 gradient only)
  // and 13 x 7 (one and two; central differences too).
  for (int a = 0; a < 4; ++a)
    for (size_t batch : {size_t{1}, size_t{3}}) {
      OpShape s{{29, 17, batch}, a, std::string(activation_name(kActivations[a])) + ", 29 x 17 x " + std::to_string(batch)};
      s.no_fd = true;
      e.shapes.push_back(s);
    }
  for (int a = 0; a < 4; ++a)
    for (size_t batch : {size_t{1}, size_t{2}})
      e.shapes.push_back({{13, 7, batch}, a, std::string(activation_name(kActivations[a])) + ", 13 x 7 x " + std::to_string(batch)});
  e.shapes.push_back({{1, 7, 1}, 2, "sigmoid, 1 x 7"});
  e.shapes.push_back({{37, 5, 2}, 3, "softplus, 2 x 37 x 5"});
  // dims[3] = 1: the strided bias gradient (NOVA_BIAS_GRAD=strided, what a GPU runs), and
  // dims[3] = 2: the row walk (NOVA_BIAS_GRAD=row-walk, a CPU's kernel), so that every device
  // runs both kernels whatever its own choice; every activation at 1009 rows of three networks
  // and at 13 x 7.
  for (int walk : {1, 2}) {
    const std::string name = walk == 1 ? ", strided" : ", row-walk";
    for (int a = 0; a < 4; ++a) {
      e.shapes.push_back({{kOddRows, 7, 3, size_t(walk)}, a, std::string(activation_name(kActivations[a])) + ", 1009 x 7 x 3" + name});
      e.shapes.push_back({{13, 7, 1, size_t(walk)}, a, std::string(activation_name(kActivations[a])) + ", 13 x 7" + name});
    }
  }
  // dims[3] = 3: a bias without a gradient (dh alone: bias_act_backward's pass).
  e.shapes.push_back({{kOddRows, 7, 2, 3}, 1, "relu, 2 x 1009 x 7, a bias without a gradient"});
  // Over 4159 rows the strided gradient takes more parts than the row walk and folds them
  // (reduce.cl's colsum_fold): 9001 rows give 140 parts, folded into 5.
  OpShape many_parts{{9001, 5, 1, 1}, 1, "relu, 9001 x 5, strided, folded parts"};
  many_parts.no_fd = true;
  e.shapes.push_back(many_parts);
  e.build = [](Graph& g, const OpShape& s) {
    const size_t rows = s.dims[0], cols = s.dims[1], batch = s.dims[2];
    Tensor h = g.input("h", batched(batch, rows, cols), true);
    const bool frozen = s.dims.size() > 3 && s.dims[3] == 3;
    Tensor b = g.input("b", batch > 1 ? Shape{batch, cols} : Shape{cols}, !frozen);
    return OpGraph{{h, b}, {bias_act(h, b, kActivations[s.variant])}, {}};
  };
  e.values = [](const OpShape& s) {
    const size_t rows = s.dims[0], cols = s.dims[1], batch = s.dims[2];
    auto h = random_floats(batch * rows * cols, -4, 4, 111);
    const auto b = random_floats(batch * cols, -1, 1, 112);
    // Keep h + b 1e-3 from ReLU's kink, where float32 and float64 could disagree on the side
    // (0.05 for the finite differences' step of 1e-2).
    const float margin = rows <= 64 ? 0.05f : 1e-3f;
    for (size_t i = 0; i < h.size(); ++i) {
      const float bias = b[(i / (rows * cols)) * cols + i % cols];
      if (std::fabs(h[i] + bias) < margin) h[i] = margin - bias;
    }
    return std::vector<std::vector<float>>{h, b};
  };
  const auto compute = [](const OpCase& c, bool grad) {
    const size_t rows = c.shape.dims[0], cols = c.shape.dims[1];
    const Activation a = kActivations[c.shape.variant];
    const auto &h = c.values[0], &b = c.values[1];
    std::vector<double> ref(h.size()), dh(h.size()), db(b.size(), 0.0), db_abs(b.size(), 0.0);
    for (size_t i = 0; i < h.size(); ++i) {
      const size_t bi = (i / (rows * cols)) * cols + i % cols;
      const double x = double(h[i]) + b[bi];
      ref[i] = activation_reference(a, x);
      if (!grad) continue;
      dh[i] = c.upstream[0][i] * act_slope(a, x);
      db[bi] += dh[i];
      db_abs[bi] += std::fabs(dh[i]);
    }
    return std::vector<std::vector<double>>{ref, dh, db, db_abs};
  };
  // One rounding of the sum, <= 4 ulp for exp/log1p.
  e.reference = [=](const OpCase& c) { return std::vector<Expected>{{compute(c, false)[0], {1e-6, 1e-5}}}; };
  e.gradient = [=](const OpCase& c) {
    auto r = compute(c, true);
    // The bias gradient is a float32 two-stage sum of up to 1009 terms: error <= 1e-5 of the
    // sum of their magnitudes.
    const double db_scale = *std::max_element(r[3].begin(), r[3].end());
    if (c.shape.dims.size() > 3 && c.shape.dims[3] == 3) return std::vector<Expected>{grad_expected(r[1]), {}};
    return std::vector<Expected>{grad_expected(r[1]), {r[2], {1e-5 * db_scale, 0}}};
  };
  e.fd = GradCheckOptions{};
  e.flops = [](const OpShape& s) { return double(s.dims[0] * s.dims[1] * s.dims[2]) * 8; };
  // The bias gradient's summation is chosen by NOVA_BIAS_GRAD when the op runs: the strided
  // and row-walk shapes ask for theirs, the rest run the device's own.
  e.prepare = [](const OpShape& s, const Runtime&) -> std::string {
    if (s.dims.size() > 3 && s.dims[3] == 1) setenv("NOVA_BIAS_GRAD", "strided", 1);
    if (s.dims.size() > 3 && s.dims[3] == 2) setenv("NOVA_BIAS_GRAD", "row-walk", 1);
    return "";
  };
  e.restore = [] { unsetenv("NOVA_BIAS_GRAD"); };
  return e;
}

OpEntry linear_entry(bool with_bias) {
  OpEntry e;
  e.name = with_bias ? "dense" : "linear";
  // dims: M, K, N, B (variant: dense's activation). K <= 9 keeps the tolerance below.
  e.shapes = {{{1, 5, 3, 1}, 2, "1 x 5 -> 3"}, {{37, 7, 5, 1}, 3, "37 x 7 -> 5"}, {{13, 7, 11, 3}, 0, "3 x 13 x 7 -> 11"},
              {{23, 9, 5, 1}, 0, "23 x 9 -> 5"}, {{23, 9, 5, 2}, 2, "2 x 23 x 9 -> 5"},
              {{kOddRows, 5, 21, 1}, 1, "1009 x 5 -> 21"}};
  e.build = [with_bias](Graph& g, const OpShape& s) {
    const size_t M = s.dims[0], K = s.dims[1], N = s.dims[2], B = s.dims[3];
    Tensor x = g.input("x", batched(B, M, K), true), w = g.input("w", batched(B, K, N), true);
    if (!with_bias) return OpGraph{{x, w}, {linear(x, w)}, {}};
    Tensor b = g.input("b", B > 1 ? Shape{B, N} : Shape{N}, true);
    return OpGraph{{x, w, b}, {dense(x, w, b, kActivations[s.variant])}, {}};
  };
  e.values = [with_bias](const OpShape& s) {
    const size_t M = s.dims[0], K = s.dims[1], N = s.dims[2], B = s.dims[3];
    std::vector<std::vector<float>> v = {random_floats(B * M * K, -1, 1, 201), random_floats(B * K * N, -1, 1, 202)};
    if (with_bias) v.push_back(random_floats(B * N, -1, 1, 203));
    return v;
  };
  e.reference = [with_bias](const OpCase& c) {
    const size_t M = c.shape.dims[0], K = c.shape.dims[1], N = c.shape.dims[2], B = c.shape.dims[3];
    auto y = matmul(c.values[0], c.values[1], B, M, K, N);
    if (with_bias)
      for (size_t i = 0; i < y.size(); ++i)
        y[i] = activation_reference(kActivations[c.shape.variant], y[i] + c.values[2][(i / (M * N)) * N + i % N]);
    // K <= 9 products of values in [-1, 1]: |err| <= 2 * 9 * 2^-24 * 9 < 1e-5 (a bias and
    // an activation add a rounding of a value <= 10).
    return std::vector<Expected>{{y, {1e-5, 0}}};
  };
  // The finite differences cross ReLU's kink nowhere: the small shapes use sigmoid,
  // softplus and identity.
  e.fd = GradCheckOptions{};
  e.flops = [](const OpShape& s) { return 6.0 * double(s.dims[3] * s.dims[0] * s.dims[1] * s.dims[2]); };
  return e;
}

// concat (variant 0, dims rows, W0, W1[, W2]: [rows, W0] beside [rows, W1] ...; variant 2 the
// same with the middle part taking no gradient) and stack (variant 1, dims M, C, B: [M, C] on
// top of [B, M, C], the static and object NeRFs' outputs for render_composite), both copies
// of their parts: exact forward, the upstream gradient split. Two parts run as one launch
// (copy_cols2), a third on its own (copy_cols).
OpEntry concat_entry() {
  OpEntry e;
  e.name = "concat";
  e.shapes = {{{kOddRows, 3, 5}, 0, "1009 x (3 + 5)"},
              {{13, 3, 5}, 0, "13 x (3 + 5)"},
              {{1, 3, 5}, 0, "1 x (3 + 5)"},
              {{kOddRows, 3, 2, 5}, 0, "1009 x (3 + 2 + 5)"},
              {{13, 3, 5, 4}, 2, "13 x (3 + 5 + 4), the middle part without a gradient"},
              {{6, 5, 2}, 1, "stack [6, 5] on [2, 6, 5]"}};
  const auto widths = [](const OpShape& s) { return std::vector<size_t>(s.dims.begin() + 1, s.dims.end()); };
  e.build = [=](Graph& g, const OpShape& s) {
    if (s.variant == 1) {
      Tensor a = g.input("a", Shape{s.dims[0], s.dims[1]}, true);
      Tensor b = g.input("b", Shape{s.dims[2], s.dims[0], s.dims[1]}, true);
      return OpGraph{{a, b}, {stack({a, b})}, {}};
    }
    std::vector<Tensor> parts;
    const std::vector<size_t> w = widths(s);
    for (size_t i = 0; i < w.size(); ++i)
      parts.push_back(g.input(std::string(1, static_cast<char>('a' + i)), Shape{s.dims[0], w[i]}, !(s.variant == 2 && i == 1)));
    return OpGraph{parts, {concat(parts)}, {}};
  };
  e.values = [=](const OpShape& s) {
    if (s.variant == 1)
      return std::vector<std::vector<float>>{random_floats(s.dims[0] * s.dims[1], -1, 1, 1),
                                             random_floats(s.dims[2] * s.dims[0] * s.dims[1], -1, 1, 2)};
    std::vector<std::vector<float>> v;
    const std::vector<size_t> w = widths(s);
    for (size_t i = 0; i < w.size(); ++i) v.push_back(random_floats(s.dims[0] * w[i], -1, 1, 121 + static_cast<unsigned>(i)));
    return v;
  };
  // Columns [first, first + width) of every row; a stack's parts are one leading block each.
  const auto split = [=](const OpShape& s, const auto& full, size_t part) {
    const std::vector<size_t> w = s.variant == 1 ? std::vector<size_t>{s.dims[0] * s.dims[1], s.dims[2] * s.dims[0] * s.dims[1]} : widths(s);
    const size_t rows = s.variant == 1 ? 1 : s.dims[0], W = full.size() / rows;
    size_t first = 0;
    for (size_t i = 0; i < part; ++i) first += w[i];
    std::vector<double> v;
    for (size_t r = 0; r < rows; ++r)
      for (size_t c = first; c < first + w[part]; ++c) v.push_back(full[r * W + c]);
    return v;
  };
  e.reference = [=](const OpCase& c) {
    if (c.shape.variant == 1) {
      std::vector<double> ref = to_double(c.values[0]);
      ref.insert(ref.end(), c.values[1].begin(), c.values[1].end());
      return std::vector<Expected>{{ref, {0, 0}}};  // a copy: exact
    }
    std::vector<double> ref;
    const std::vector<size_t> w = widths(c.shape);
    for (size_t r = 0; r < c.shape.dims[0]; ++r)
      for (size_t i = 0; i < w.size(); ++i)
        for (size_t k = 0; k < w[i]; ++k) ref.push_back(c.values[i][r * w[i] + k]);
    return std::vector<Expected>{{ref, {0, 0}}};  // a copy: exact
  };
  e.gradient = [=](const OpCase& c) {
    const size_t parts = c.shape.variant == 1 ? 2 : c.shape.dims.size() - 1;
    std::vector<Expected> out;
    for (size_t i = 0; i < parts; ++i)
      out.push_back(c.shape.variant == 2 && i == 1 ? Expected{} : grad_expected(split(c.shape, c.upstream[0], i)));
    return out;
  };
  e.fd = GradCheckOptions{};
  e.flops = [](const OpShape&) { return 0.0; };
  return e;
}

// Gate values 0, 1 and soft ones, row by row.
std::vector<float> mixed_gate(size_t n, unsigned seed) {
  auto g = random_floats(n, 0, 1, seed);
  for (float& v : g) v = v < 0.35f ? 0.0f : v < 0.7f ? 1.0f : v;
  return g;
}

// The forward is a copy (exact). Variant 0: the gated gradient against the device's upstream
// (harness tolerance). Variant 1: x is also read ungated, loss = mse(y, t) + mse(x, t2), so
// the gate's backward accumulates into x's gradient: one float32 product per element and one
// addition, rtol 1e-5 with atol 1e-7. Variant 2: an all-ones gate is the identity, so central
// differences (harness default) apply; elsewhere the backward is deliberately not the
// forward's derivative and no finite differences run. The gated columns (the last dim) are the
// first few; the rest pass their gradient whole (the static NeRF's blend, which learns from
// every ray).
OpEntry gradient_gate_entry() {
  OpEntry e;
  e.name = "gradient_gate";
  // dims: rays R, rows per ray G, cols C, gate rows, gate row, gated columns.
  e.shapes = {{{kOddRows, 3, 5, 2, 1, 5}, 0, "1009 x 3 rows x 5, gate row 1 of 2"},
              {{kOddRows, 3, 5, 2, 1, 4}, 0, "1009 x 3 rows x 5, gate row 1 of 2, column 4 ungated"},
              {{1, 1, 3, 1, 0, 3}, 0, "1 x 1 x 3"},
              {{13, 3, 5, 2, 1, 5}, 1, "13 x 3 rows x 5, gate row 1 of 2, x also read ungated"},
              {{13, 3, 5, 2, 1, 2}, 1, "13 x 3 rows x 5, gate row 1 of 2, columns 2-4 ungated, x also read ungated"},
              {{7, 4, 3, 1, 0, 3}, 2, "7 x 4 rows x 3, all-ones gate", GradCheckOptions{}}};
  e.build = [](Graph& g, const OpShape& s) {
    const Shape rows{s.dims[0] * s.dims[1], s.dims[2]};
    Tensor x = g.input("x", rows, true), gate = g.input("gate", Shape{s.dims[3], s.dims[0]});
    Tensor y = gradient_gate(x, gate, s.dims[4], s.dims[5]);
    if (s.variant != 1) return OpGraph{{x, gate}, {y}, {}};
    Tensor t = g.input("t", rows), t2 = g.input("t2", rows);
    return OpGraph{{x, gate, t, t2}, {y}, weighted_sum({mse(y, t), mse(x, t2)}, {1.0f, 1.0f})};
  };
  e.values = [](const OpShape& s) {
    const size_t R = s.dims[0], n = R * s.dims[1] * s.dims[2];
    if (s.variant == 1)
      return std::vector<std::vector<float>>{random_floats(n, -1, 1, 1), mixed_gate(s.dims[3] * R, 4),
                                             random_floats(n, -1, 1, 2), random_floats(n, -1, 1, 3)};
    if (s.variant == 2)
      return std::vector<std::vector<float>>{random_floats(n, -1, 1, 5), std::vector<float>(s.dims[3] * R, 1.0f)};
    auto gate = random_floats(s.dims[3] * R, 0, 1, 126);
    for (float& v : gate) v = v < 0.5f ? 0.0f : v;
    return std::vector<std::vector<float>>{random_floats(n, -1, 1, 124), gate};
  };
  e.reference = [](const OpCase& c) { return std::vector<Expected>{{to_double(c.values[0]), {0, 0}}}; };  // a copy
  e.gradient = [](const OpCase& c) {
    const size_t R = c.shape.dims[0], per_ray = c.shape.dims[1] * c.shape.dims[2], row = c.shape.dims[4];
    const size_t cols = c.shape.dims[2], gated = c.shape.dims[5];
    const auto& x = c.values[0];
    std::vector<double> dx(x.size());
    for (size_t i = 0; i < dx.size(); ++i) {
      const double gate = i % cols < gated ? c.values[1][row * R + i / per_ray] : 1.0;
      if (c.shape.variant != 1) {
        dx[i] = c.upstream[0][i] * gate;
        continue;
      }
      const double n = static_cast<double>(x.size());
      dx[i] = 2.0 * (double(x[i]) - c.values[2][i]) / n * gate + 2.0 * (double(x[i]) - c.values[3][i]) / n;
    }
    if (c.shape.variant == 1) return std::vector<Expected>{{dx, {1e-7, 1e-5}}, {}, {}, {}};
    return std::vector<Expected>{grad_expected(dx), {}};
  };
  e.flops = [](const OpShape& s) { return double(s.dims[0] * s.dims[1] * s.dims[2]); };
  return e;
}

OpEntry repeat_rows_entry() {
  OpEntry e;
  e.name = "repeat_rows";
  // dims: batches B, cols C, rows. Its input is data (no gradient).
  e.shapes = {{{3, 2, kOddRows}, 0, "[3, 2] -> [3, 1009, 2]"}, {{1, 3, 1}, 0, "[1, 3] -> [1, 3]"}};
  e.build = [](Graph& g, const OpShape& s) {
    Tensor x = g.input("per_batch", Shape{s.dims[0], s.dims[1]});
    return OpGraph{{x}, {repeat_rows(x, s.dims[2])}, {}};
  };
  e.values = [](const OpShape& s) { return std::vector<std::vector<float>>{random_floats(s.dims[0] * s.dims[1], -1, 1, 127)}; };
  e.reference = [](const OpCase& c) {
    std::vector<double> ref;
    for (size_t b = 0; b < c.shape.dims[0]; ++b)
      for (size_t r = 0; r < c.shape.dims[2]; ++r)
        for (size_t k = 0; k < c.shape.dims[1]; ++k) ref.push_back(c.values[0][b * c.shape.dims[1] + k]);
    return std::vector<Expected>{{ref, {0, 0}}};  // a copy: exact
  };
  e.flops = [](const OpShape&) { return 0.0; };
  return e;
}

OpEntry scale_columns_entry() {
  OpEntry e;
  e.name = "scale_columns";
  // dims: rows M, cols C, batches B (x [M, C] for B = 1, else [B, M, C]); weights [C] are data.
  e.shapes = {{{kOddRows, 6, 1}, 0, "1009 x 6"},
              {{1, 3, 1}, 0, "1 x 3"},
              {{13, 4, 3}, 0, "[3, 13, 4], weights shared by the batches"}};
  e.build = [](Graph& g, const OpShape& s) {
    const Shape xs = s.dims[2] == 1 ? Shape{s.dims[0], s.dims[1]} : Shape{s.dims[2], s.dims[0], s.dims[1]};
    Tensor x = g.input("x", xs, true), w = g.input("w", Shape{s.dims[1]});
    return OpGraph{{x, w}, {scale_columns(x, w)}, {}};
  };
  e.values = [](const OpShape& s) {
    // Weights in [0, 1] with an exact 1 and 0, as a coarse-to-fine window has.
    auto w = random_floats(s.dims[1], 0, 1, 129);
    w[0] = 1.0f;
    if (w.size() > 2) w.back() = 0.0f;
    return std::vector<std::vector<float>>{random_floats(s.dims[0] * s.dims[1] * s.dims[2], -1, 1, 128), w};
  };
  // One float32 product per element, correctly rounded: within 2^-24 relative (rtol 6e-8).
  e.reference = [](const OpCase& c) {
    const size_t C = c.shape.dims[1];
    std::vector<double> ref;
    for (size_t i = 0; i < c.values[0].size(); ++i) ref.push_back(double(c.values[0][i]) * c.values[1][i % C]);
    return std::vector<Expected>{{ref, {0, 6e-8}}};
  };
  e.gradient = [](const OpCase& c) {
    const size_t C = c.shape.dims[1];
    std::vector<double> dx;
    for (size_t i = 0; i < c.upstream[0].size(); ++i) dx.push_back(c.upstream[0][i] * c.values[1][i % C]);
    return std::vector<Expected>{grad_expected(dx), {}};
  };
  e.fd = GradCheckOptions{};
  e.flops = [](const OpShape& s) { return 2.0 * double(s.dims[0] * s.dims[1] * s.dims[2]); };
  return e;
}

OpEntry bounded_offset_entry() {
  OpEntry e;
  e.name = "bounded_offset";
  // dims: rows M, batches B (y and raw [M, 3] for B = 1, else [B, M, 3]); the bound is 0.05.
  e.shapes = {{{kOddRows, 1}, 0, "1009 x 3"}, {{1, 1}, 0, "1 x 3"}, {{13, 3}, 0, "[3, 13, 3]"}};
  e.build = [](Graph& g, const OpShape& s) {
    const Shape ys = s.dims[1] == 1 ? Shape{s.dims[0], 3} : Shape{s.dims[1], s.dims[0], 3};
    Tensor y = g.input("y", ys, true), raw = g.input("raw", ys, true);
    return OpGraph{{y, raw}, {bounded_offset(y, raw, 0.05f)}, {}};
  };
  e.values = [](const OpShape& s) {
    // raw over [-3, 3]: tanh's flat tails and its steep middle.
    const size_t n = s.dims[0] * s.dims[1] * 3;
    return std::vector<std::vector<float>>{random_floats(n, -1, 1, 131), random_floats(n, -3, 3, 132)};
  };
  // float32 tanh is within 4 ulp (OpenCL 1.2's bound for tanh), times 0.05, plus one rounded
  // addition to y in [-1, 1]: 1e-7 absolute holds both.
  e.reference = [](const OpCase& c) {
    std::vector<double> ref;
    for (size_t i = 0; i < c.values[0].size(); ++i) ref.push_back(double(c.values[0][i]) + 0.05 * std::tanh(double(c.values[1][i])));
    return std::vector<Expected>{{ref, {1e-7, 0}}};
  };
  e.gradient = [](const OpCase& c) {
    std::vector<double> dy, draw;
    for (size_t i = 0; i < c.upstream[0].size(); ++i) {
      const double t = std::tanh(double(c.values[1][i]));
      dy.push_back(c.upstream[0][i]);
      draw.push_back(c.upstream[0][i] * 0.05 * (1 - t * t));
    }
    return std::vector<Expected>{grad_expected(dy), grad_expected(draw)};
  };
  e.fd = GradCheckOptions{};
  e.flops = [](const OpShape& s) { return 20.0 * double(s.dims[0] * s.dims[1] * 3); };
  return e;
}

OpEntry box_coordinates_entry() {
  OpEntry e;
  e.name = "box_coordinates";
  // dims: rows M, batches B (x [M, 3] and box [6] for B = 1, else [B, M, 3] and [B, 6]).
  e.shapes = {{{kOddRows, 1}, 0, "1009 x 3"}, {{1, 1}, 0, "1 x 3"}, {{13, 3}, 0, "[3, 13, 3]"}};
  e.build = [](Graph& g, const OpShape& s) {
    const bool batched = s.dims[1] > 1;
    Tensor x = g.input("x", batched ? Shape{s.dims[1], s.dims[0], 3} : Shape{s.dims[0], 3}, true);
    Tensor box = g.input("box", batched ? Shape{s.dims[1], 6} : Shape{6});
    return OpGraph{{x, box}, {box_coordinates(x, box)}, {}};
  };
  e.values = [](const OpShape& s) {
    // Centres in [-1, 1], log scales in [-1, 3] (a box down to 1/20 of the scene's).
    auto box = random_floats(s.dims[1] * 6, -1, 1, 134);
    const auto logs = random_floats(s.dims[1] * 3, -1, 3, 135);
    for (size_t b = 0; b < s.dims[1]; ++b)
      for (size_t j = 0; j < 3; ++j) box[b * 6 + 3 + j] = logs[b * 3 + j];
    return std::vector<std::vector<float>>{random_floats(s.dims[0] * s.dims[1] * 3, -1, 1, 133), box};
  };
  // float32: x - c of two floats rounds once (2^-24 relative), exp is within 3 ulp (OpenCL
  // 1.2's bound, <= 3 * 2^-23 relative) and the product rounds once: 4.8e-7 relative in all.
  e.reference = [](const OpCase& c) {
    const size_t rows = c.shape.dims[0] * 3;
    std::vector<double> ref;
    for (size_t i = 0; i < c.values[0].size(); ++i) {
      const size_t b = i / rows, j = i % 3;
      ref.push_back((double(c.values[0][i]) - c.values[1][b * 6 + j]) * std::exp(double(c.values[1][b * 6 + 3 + j])));
    }
    return std::vector<Expected>{{ref, {0, 1e-6}}};
  };
  e.gradient = [](const OpCase& c) {
    const size_t rows = c.shape.dims[0] * 3;
    std::vector<double> dx;
    for (size_t i = 0; i < c.upstream[0].size(); ++i)
      dx.push_back(c.upstream[0][i] * std::exp(double(c.values[1][(i / rows) * 6 + 3 + i % 3])));
    return std::vector<Expected>{grad_expected(dx), {}};
  };
  e.fd = GradCheckOptions{};
  e.flops = [](const OpShape& s) { return 20.0 * double(s.dims[0] * s.dims[1] * 3); };
  return e;
}

OpEntry random_entry(bool normal) {
  OpEntry e;
  e.name = normal ? "random_normal" : "random_uniform";
  e.shapes = {{{kOddRows}, 0, "1009"}, {{1}, 0, "1"}};
  const uint32_t stream = normal ? 2 : 1;
  e.build = [=](Graph& g, const OpShape& s) {
    auto counter = std::make_shared<DrawCounter>();
    counter->value = 3;
    const RandomStream rs{5, stream, counter};
    return OpGraph{{}, {normal ? random_normal(g, "z", Shape{s.dims[0]}, rs) : random_uniform(g, "u", Shape{s.dims[0]}, rs)}, {}};
  };
  e.values = [](const OpShape&) { return std::vector<std::vector<float>>{}; };
  e.reference = [=](const OpCase& c) {
    std::vector<double> ref;
    for (size_t i = 0; i < c.shape.dims[0]; ++i) ref.push_back(random_reference(normal, i, 5, stream, 3));
    // Uniform values are multiples of 2^-24: exact. Normal's log/sqrt/cos/sin are within 4 ulp
    // each (tests/test_device_random.cpp).
    return std::vector<Expected>{{ref, normal ? Tolerance{2e-6, 2e-6} : Tolerance{0, 0}}};
  };
  e.flops = [=](const OpShape& s) { return double(s.dims[0]) * (normal ? 40 : 4); };
  return e;
}

}  // namespace

void register_core_ops(std::vector<OpEntry>& t) {
  t.push_back(positional_encoding_entry());
  t.push_back(bias_act_entry());
  t.push_back(linear_entry(false));
  t.push_back(linear_entry(true));
  t.push_back(concat_entry());
  t.push_back(gradient_gate_entry());
  t.push_back(repeat_rows_entry());
  t.push_back(scale_columns_entry());
  t.push_back(bounded_offset_entry());
  t.push_back(box_coordinates_entry());
  t.push_back(random_entry(false));
  t.push_back(random_entry(true));
}

}  // namespace nova::test

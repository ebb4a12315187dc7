// nova-bench render: samples/s of the compositing op (render_composite), forward and
// backward, for 1 + K NeRFs at 65536 rays x 64 samples, beside a plain single-threaded C++
// loop of the same maths in the same run (and a check that both give the same numbers).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <random>
#include <sstream>

#include "bench.hpp"
#include "nova/executor.hpp"
#include "nova/ops.hpp"
#include "nova/render.hpp"
#include "options.hpp"

namespace nova::bench {
namespace {

constexpr int kMaxNerfs = 16;

float sigmoid(float x) { return 1.0f / (1.0f + std::exp(-x)); }

// The host loop: raw [N, R, S, 5] (raw activations), delta and z [R, S]; forward writes
// rgb, masks, depth, acc and per-NeRF rgb; backward takes upstream gradients of rgb and the
// masks only (the losses that train through them) and writes d raw.
struct HostRender {
  int N, R, S;
  const float *raw, *delta, *z;

  struct Sample {
    float alpha[kMaxNerfs], trans[kMaxNerfs], dadraw[kMaxNerfs], blend[kMaxNerfs],
        dblend[kMaxNerfs], c[kMaxNerfs][3], dc[kMaxNerfs][3], b[kMaxNerfs], inv;
  };

  void load(int r, int i, Sample& s) const {
    float bsum = 0;
    for (int n = 0; n < N; ++n) {
      const size_t at = (static_cast<size_t>(n) * R + r) * S + i;
      const float* p = raw + at * 5;
      const float sig = std::max(p[3], 0.0f), d = delta[static_cast<size_t>(r) * S + i];
      s.alpha[n] = -std::expm1(-sig * d);
      s.trans[n] = std::exp(-sig * d);
      s.dadraw[n] = p[3] > 0 && s.trans[n] > 0 ? s.trans[n] * d : 0.0f;
      s.blend[n] = sigmoid(p[4]);
      s.dblend[n] = s.blend[n] * (1 - s.blend[n]);
      for (int k = 0; k < 3; ++k) {
        s.c[n][k] = sigmoid(p[k]);
        s.dc[n][k] = s.c[n][k] * (1 - s.c[n][k]);
      }
      bsum += s.blend[n];
    }
    s.inv = 1.0f / (bsum + 1e-6f);
    for (int n = 0; n < N; ++n) s.b[n] = s.blend[n] * s.inv;
  }

  void forward(float* rgb, float* nerf_rgb, float* mask, float* depth, float* acc) const {
    Sample s;
    for (int r = 0; r < R; ++r) {
      float T = 1, Tn[kMaxNerfs], col[3] = {0, 0, 0}, m[kMaxNerfs], cn[kMaxNerfs][3], d = 0, a = 0;
      for (int n = 0; n < N; ++n) Tn[n] = 1, m[n] = 0, cn[n][0] = cn[n][1] = cn[n][2] = 0;
      for (int i = 0; i < S; ++i) {
        load(r, i, s);
        float P = 1, A = 0;
        for (int n = 0; n < N; ++n) {
          const float ab = s.alpha[n] * s.b[n];
          A += P * ab;
          P *= 1 - ab;
          for (int k = 0; k < 3; ++k) col[k] += T * ab * s.c[n][k], cn[n][k] += Tn[n] * s.alpha[n] * s.c[n][k];
          Tn[n] *= s.trans[n] + 1e-10f;
        }
        for (int n = 0; n < N; ++n) m[n] += T * A * s.b[n];
        d += T * A * z[static_cast<size_t>(r) * S + i];
        a += T * A;
        T *= P + 1e-10f;
      }
      for (int k = 0; k < 3; ++k) rgb[r * 3 + k] = col[k];
      for (int n = 0; n < N; ++n) {
        mask[static_cast<size_t>(n) * R + r] = m[n];
        for (int k = 0; k < 3; ++k) nerf_rgb[(static_cast<size_t>(n) * R + r) * 3 + k] = cn[n][k];
      }
      depth[r] = d;
      acc[r] = a;
    }
  }

  // Reverse scan with T_i kept in a per-ray buffer (the same algorithm as the kernel).
  void backward(const float* g_rgb, const float* g_mask, float* g_raw) const {
    Sample s;
    std::vector<float> Ts(S);
    for (int r = 0; r < R; ++r) {
      float T = 1;
      for (int i = 0; i < S; ++i) {
        load(r, i, s);
        Ts[i] = T;
        float P = 1;
        for (int n = 0; n < N; ++n) P *= 1 - s.alpha[n] * s.b[n];
        T *= P + 1e-10f;
      }
      float Rs = 0;
      for (int i = S - 1; i >= 0; --i) {
        load(r, i, s);
        float A = 0, P = 1, G = 0, q[kMaxNerfs], gcc[kMaxNerfs], gb[kMaxNerfs], gbsum = 0;
        for (int n = 0; n < N; ++n) {
          const float ab = s.alpha[n] * s.b[n];
          A += P * ab;
          P *= 1 - ab;
          q[n] = 1 - ab;
          gcc[n] = g_rgb[r * 3] * s.c[n][0] + g_rgb[r * 3 + 1] * s.c[n][1] + g_rgb[r * 3 + 2] * s.c[n][2];
          G += g_mask[static_cast<size_t>(n) * R + r] * s.b[n];
        }
        const float gP = Ts[i] * (Rs - G);
        float h = A * G;
        for (int n = 0; n < N; ++n) {
          float others = 1;
          for (int m = 0; m < N; ++m)
            if (m != n) others *= q[m];
          h += s.alpha[n] * s.b[n] * gcc[n];
          const float ga = Ts[i] * s.b[n] * gcc[n] - gP * others * s.b[n];
          gb[n] = Ts[i] * (s.alpha[n] * gcc[n] + A * g_mask[static_cast<size_t>(n) * R + r]) -
                  gP * others * s.alpha[n];
          gbsum += gb[n] * s.b[n];
          float* g = g_raw + ((static_cast<size_t>(n) * R + r) * S + i) * 5;
          for (int k = 0; k < 3; ++k) g[k] = Ts[i] * s.alpha[n] * s.b[n] * g_rgb[r * 3 + k] * s.dc[n][k];
          g[3] = ga * s.dadraw[n];
        }
        for (int n = 0; n < N; ++n)
          g_raw[((static_cast<size_t>(n) * R + r) * S + i) * 5 + 4] = (gb[n] - gbsum) * s.inv * s.dblend[n];
        Rs = h + (P + 1e-10f) * Rs;
      }
    }
  }
};

double seconds_since(std::chrono::steady_clock::time_point a) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count();
}

double max_abs_diff(const std::vector<float>& a, const std::vector<float>& b) {
  double m = 0;
  for (size_t i = 0; i < a.size(); ++i) m = std::max(m, static_cast<double>(std::fabs(a[i] - b[i])));
  return m;
}

}  // namespace

int render(const Args& args) {
  const Options o(args, {{"rays", "65536"}, {"samples", "64"}, {"objects", "0,1,3"},
                         {"repeats", "3"}, {"device", ""}});
  if (o.help()) {
    std::cout << o.usage("nova-bench render");
    return 0;
  }
  const size_t R = static_cast<size_t>(o.integer("rays")), S = static_cast<size_t>(o.integer("samples"));
  const int repeats = static_cast<int>(o.integer("repeats"));
  Runtime rt(select_device(o.str("device")));
  std::cout << "device " << rt.info().name << " (" << rt.info().type_name() << "); host loop: "
            << "plain C++, 1 thread\n"
            << R << " rays x " << S << " samples; samples/s counts samples along rays (each "
            << "evaluated for all 1 + K NeRFs); median of " << repeats << " after a warm-up\n\n";
  std::cout << std::left << std::setw(4) << "K" << std::setw(10) << "pass" << std::right
            << std::setw(16) << "device s/s" << std::setw(16) << "host s/s" << std::setw(10)
            << "ratio" << std::setw(14) << "max |diff|" << "\n";
  std::ostringstream csv;
  csv << "objects,pass,rays,samples,device_samples_per_s,host_samples_per_s,device_over_host,"
         "max_abs_diff\n";

  for (long K : o.integers("objects")) {
    const size_t N = static_cast<size_t>(K) + 1;
    // Plausible raw fields: rgb and blend logits in [-3, 3], sigma in [-1, 4].
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> u(-3, 3), us(-1, 4);
    std::vector<float> raw(N * R * S * 5), delta(R * S), z(R * S);
    for (size_t e = 0; e < raw.size(); ++e) raw[e] = e % 5 == 3 ? us(rng) : u(rng);
    for (size_t e = 0; e < R * S; ++e) {
      delta[e] = e % S + 1 == S ? 1e10f : 1.0f / S;
      z[e] = static_cast<float>(e % S) / S;
    }
    Graph g;
    Tensor traw = g.input("raw", Shape{N, R * S, 5}, true), td = g.input("delta", Shape{R, S}),
           tz = g.input("z", Shape{R, S}), target = g.input("target", Shape{R, 3}),
           tmask = g.input("masks", Shape{N, R});
    RenderOutputs out = render_composite(traw, td, tz);
    g.keep(out.rgb);
    g.keep(out.mask);
    // The losses that train through the render: colour and masks.
    g.set_loss(weighted_sum({mse(out.rgb, target), mse(out.mask, tmask)}, {1.0f, 1.0f}));
    Executor ex(rt, g);
    ex.set(traw, raw);
    ex.set(td, delta);
    ex.set(tz, z);
    ex.set(target, std::vector<float>(R * 3, 0.5f));
    ex.set(tmask, std::vector<float>(N * R, 0.5f));

    const double dev_fwd = time_median(repeats, [&] {
      ex.forward();
      rt.finish();
    });
    // Backward alone: a forward before each timed backward.
    std::vector<double> bt;
    for (int i = 0; i <= repeats; ++i) {
      ex.forward();
      rt.finish();
      const auto a = std::chrono::steady_clock::now();
      ex.backward();
      rt.finish();
      if (i > 0) bt.push_back(seconds_since(a));  // the first is the warm-up
    }
    std::sort(bt.begin(), bt.end());
    const double dev_bwd = bt[bt.size() / 2];
    ex.forward();
    const auto dev_rgb = ex.get(out.rgb), dev_mask = ex.get(out.mask);
    ex.backward();
    const auto dev_grad = ex.get_grad(traw);

    // The host loop, with the upstream gradients mse gives: 2/n (out - target).
    HostRender host{static_cast<int>(N), static_cast<int>(R), static_cast<int>(S), raw.data(),
                    delta.data(), z.data()};
    std::vector<float> rgb(R * 3), nerf_rgb(N * R * 3), mask(N * R), depth(R), acc(R);
    const double host_fwd = time_median(repeats, [&] {
      host.forward(rgb.data(), nerf_rgb.data(), mask.data(), depth.data(), acc.data());
    });
    std::vector<float> g_rgb(R * 3), g_mask(N * R), g_raw(raw.size());
    for (size_t e = 0; e < g_rgb.size(); ++e) g_rgb[e] = 2.0f / (R * 3) * (rgb[e] - 0.5f);
    for (size_t e = 0; e < g_mask.size(); ++e) g_mask[e] = 2.0f / (N * R) * (mask[e] - 0.5f);
    const double host_bwd = time_median(repeats, [&] { host.backward(g_rgb.data(), g_mask.data(), g_raw.data()); });

    const double fwd_diff = std::max(max_abs_diff(dev_rgb, rgb), max_abs_diff(dev_mask, mask));
    double gscale = 1e-30;
    for (float x : g_raw) gscale = std::max(gscale, static_cast<double>(std::fabs(x)));
    const double bwd_diff = max_abs_diff(dev_grad, g_raw) / gscale;  // relative to the largest
    const double total = static_cast<double>(R * S);
    for (int pass = 0; pass < 2; ++pass) {
      const double d = total / (pass ? dev_bwd : dev_fwd), h = total / (pass ? host_bwd : host_fwd);
      const char* name = pass ? "backward" : "forward";
      const double diff = pass ? bwd_diff : fwd_diff;
      std::cout << std::left << std::setw(4) << K << std::setw(10) << name << std::right
                << std::fixed << std::setprecision(0) << std::setw(16) << d << std::setw(16) << h
                << std::setprecision(2) << std::setw(10) << d / h << std::scientific
                << std::setprecision(1) << std::setw(14) << diff << std::defaultfloat << std::endl;
      csv << K << "," << name << "," << R << "," << S << "," << d << "," << h << "," << d / h
          << "," << diff << "\n";
    }
  }
  std::cout << "\n(max |diff|: forward over rgb and masks; backward relative to the largest "
               "|d loss / d raw|)\n\nCSV\n"
            << csv.str();
  return 0;
}

}  // namespace nova::bench

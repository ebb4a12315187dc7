// nova-bench render: samples/s of the compositing op (render_composite), forward and
// backward, for 1 + K NeRFs at 65536 rays x 64 samples, beside a plain single-threaded C++
// loop of the same maths in the same run (and a check that both give the same numbers).
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "bench.hpp"
#include "composite_problem.hpp"
#include "nova/runtime/runtime.hpp"
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
    std::cout << o.usage("nova-bench render")
              << "\nSamples/s of the compositing op (render_composite), forward and backward, beside a\n"
                 "single-threaded C++ loop of the same maths in the same run; prints a table, then its CSV.\n\n"
                 "--rays, --samples: the batch composited (rays x samples per ray)\n"
                 "--objects: comma list of object NeRF counts K (1 + K NeRFs each)\n"
                 "--repeats: timed repetitions per measurement (the median is reported)\n"
                 "--device: OpenCL device, as nova's --device\n";
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
    CompositeProblem problem(rt, N, R, S);
    const double dev_fwd = problem.forward_seconds(repeats), dev_bwd = problem.backward_seconds(repeats);
    const CompositeProblem::Outputs dev = problem.run();
    const std::vector<float>& raw = problem.raw();

    // The host loop, with the upstream gradients mse gives: 2/n (out - target).
    HostRender host{static_cast<int>(N), static_cast<int>(R), static_cast<int>(S), raw.data(),
                    problem.delta().data(), problem.z().data()};
    std::vector<float> rgb(R * 3), nerf_rgb(N * R * 3), mask(N * R), depth(R), acc(R);
    const double host_fwd = time_median(repeats, [&] {
      host.forward(rgb.data(), nerf_rgb.data(), mask.data(), depth.data(), acc.data());
    });
    std::vector<float> g_rgb(R * 3), g_mask(N * R), g_raw(raw.size());
    for (size_t e = 0; e < g_rgb.size(); ++e) g_rgb[e] = 2.0f / (R * 3) * (rgb[e] - 0.5f);
    for (size_t e = 0; e < g_mask.size(); ++e) g_mask[e] = 2.0f / (N * R) * (mask[e] - 0.5f);
    const double host_bwd = time_median(repeats, [&] { host.backward(g_rgb.data(), g_mask.data(), g_raw.data()); });

    const double fwd_diff = std::max(max_abs_diff(dev.rgb, rgb), max_abs_diff(dev.mask, mask));
    double gscale = 1e-30;
    for (float x : g_raw) gscale = std::max(gscale, static_cast<double>(std::fabs(x)));
    const double bwd_diff = max_abs_diff(dev.grad_raw, g_raw) / gscale;  // relative to the largest
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

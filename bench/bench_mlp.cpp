// nova-bench mlp: the reference NeRF MLP (63 -> 8 x 256, input re-fed after layer index 4,
// -> 4) at large batches: forward and forward + backward samples/s and GFLOP/s on the OpenCL
// device, the per-op time table, and the same GEMM shapes through the host BLAS in the same
// run, with the ratio. The host-BLAS column is built only with OpenBLAS (NOVA_HOST_BLAS, see
// CMakeLists.txt): a GPU machine without packages measures the device alone. Fused dense
// layers (the default) are timed against the same network of linear + bias_act ops, and one
// hidden layer of each width in --fused-widths alone (dense_fusion.cpp), as ratios.
#ifdef NOVA_HOST_BLAS
#include <cblas.h>
#endif

#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>

#include "bench.hpp"
#include "dense_fusion.hpp"
#include "mlp_network.hpp"
#include "nova/graph/executor.hpp"
#include "nova/ops/linalg/gemm.hpp"
#include "nova/tuning/tuning.hpp"
#include "nova/model/mlp.hpp"
#include "options.hpp"
#include "torch_compare.hpp"
#include "torch_peer.hpp"

namespace nova::bench {
namespace {

struct LayerShape {
  size_t k, n;
};

// The GEMMs one training step runs: forward X W, backward dY W^T (not for the first layer,
// whose input needs no gradient) and X^T dY.
std::vector<LayerShape> layer_shapes(const MlpConfig& c, size_t in) {
  std::vector<LayerShape> s;
  size_t k = in;
  for (int i = 0; i < c.depth; ++i) {
    s.push_back({k, static_cast<size_t>(c.width)});
    k = i == c.skip ? in + c.width : c.width;
  }
  s.push_back({k, static_cast<size_t>(c.outputs)});
  return s;
}

double gemm_flops(const std::vector<LayerShape>& shapes, size_t m, bool backward) {
  double f = 0;
  for (size_t i = 0; i < shapes.size(); ++i) {
    const double one = 2.0 * m * shapes[i].k * shapes[i].n;
    f += one;
    if (backward) f += one + (i > 0 ? one : 0.0);
  }
  return f;
}

#ifdef NOVA_HOST_BLAS
std::string host_blas_name() {
  return "OpenBLAS " + std::to_string(openblas_get_num_threads()) + " thread(s)";
}

// The same products on the host BLAS, row-major, on buffers of the same sizes.
double host_blas_seconds(const std::vector<LayerShape>& shapes, size_t m, bool backward,
                         int repeats) {
  size_t widest = 0;
  for (const auto& s : shapes) widest = std::max({widest, s.k, s.n});
  std::vector<float> x(m * widest, 0.5f), y(m * widest, 0.25f), w(widest * widest, 0.01f),
      dw(widest * widest);
  return time_median(repeats, [&] {
    for (size_t i = 0; i < shapes.size(); ++i) {
      const int k = static_cast<int>(shapes[i].k), n = static_cast<int>(shapes[i].n);
      const int mm = static_cast<int>(m);
      cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, mm, n, k, 1.0f, x.data(), k,
                  w.data(), n, 0.0f, y.data(), n);
      if (!backward) continue;
      if (i > 0)
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasTrans, mm, k, n, 1.0f, y.data(), n,
                    w.data(), n, 0.0f, x.data(), k);
      cblas_sgemm(CblasRowMajor, CblasTrans, CblasNoTrans, k, n, mm, 1.0f, x.data(), k,
                  y.data(), n, 0.0f, dw.data(), n);
    }
  });
}

// One hidden layer's three GEMMs (forward X W, dX = dY W^T, dW = X^T dY) on the host BLAS:
// seconds of each, median of `repeats`.
std::vector<double> host_layer_seconds(size_t m, size_t w, int repeats) {
  std::vector<float> x(m * w, 0.5f), y(m * w, 0.25f), wt(w * w, 0.01f), dw(w * w);
  const int mm = static_cast<int>(m), ww = static_cast<int>(w);
  return {time_median(repeats, [&] {
            cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, mm, ww, ww, 1.0f, x.data(), ww,
                        wt.data(), ww, 0.0f, y.data(), ww);
          }),
          time_median(repeats, [&] {
            cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasTrans, mm, ww, ww, 1.0f, y.data(), ww,
                        wt.data(), ww, 0.0f, x.data(), ww);
          }),
          time_median(repeats, [&] {
            cblas_sgemm(CblasRowMajor, CblasTrans, CblasNoTrans, ww, ww, mm, 1.0f, x.data(), ww,
                        y.data(), ww, 0.0f, dw.data(), ww);
          })};
}
#else
std::string host_blas_name() { return "not built (no OpenBLAS)"; }
double host_blas_seconds(const std::vector<LayerShape>&, size_t, bool, int) { return 0; }
std::vector<double> host_layer_seconds(size_t, size_t, int) { return {0, 0, 0}; }
#endif

// The same three GEMMs of one w x w hidden layer through the device's GEMM provider.
std::vector<double> device_layer_seconds(Runtime& rt, size_t m, size_t w, int repeats,
                                         std::vector<std::string>& configs) {
  Buffer x = rt.upload_floats(std::vector<float>(m * w, 0.5f));
  Buffer y = rt.upload_floats(std::vector<float>(m * w, 0.25f));
  Buffer wt = rt.upload_floats(std::vector<float>(w * w, 0.01f));
  Buffer dw = rt.alloc(w * w * sizeof(float));
  const std::vector<GemmArgs> gemms = {
      {false, false, m, w, w, 1.0f, x.get(), w, m * w, wt.get(), w, w * w, 0.0f, y.get(), w, m * w, 1},
      {false, true, m, w, w, 1.0f, y.get(), w, m * w, wt.get(), w, w * w, 0.0f, x.get(), w, m * w, 1},
      {true, false, w, w, m, 1.0f, x.get(), w, m * w, y.get(), w, m * w, 0.0f, dw.get(), w, w * w, 1}};
  std::vector<double> secs;
  configs.clear();
  for (const GemmArgs& g : gemms) {
    Buffer temp;
    if (size_t bytes = gemm_temp_bytes(rt, g)) temp = rt.alloc(bytes);
    secs.push_back(time_median(repeats, [&] {
      gemm(rt, g, temp.get());
      rt.finish();
    }));
    const auto tuned = gemm_provider(rt) == GemmProvider::Tuned ? tuned_gemm_config(rt, g)
                                                                 : std::nullopt;
    configs.push_back(gemm_choice(rt, g).str() + (tuned ? " (tuned)" : ""));
  }
  return secs;
}

}  // namespace

int mlp(const Args& args) {
  const Options o(args, {{"batches", "16384,65536"}, {"repeats", "3"}, {"device", ""},
                         {"width", "256"}, {"depth", "8"},
                         {"gemm", "tuned"}, {"layer", "256"}, {"fused-widths", "64,256"},
                         {"torch", "auto"}, {"torch-threads", "0"}, {"torch-device", "cpu"}});
  if (o.help()) {
    std::cout << o.usage("nova-bench mlp")
              << "\nTimes the paper's MLP (63 -> depth x width -> 4) forward and training step per batch,\n"
                 "then the hidden width x width layer's GEMMs beside the host BLAS, then one fused layer\n"
                 "against its two ops, and finally PyTorch on the same MLP.\n\n"
                 "--batches: comma list of row counts (samples) per pass\n"
                 "--repeats: timed repetitions per measurement (the median is reported)\n"
                 "--width, --depth: the MLP's hidden width and number of hidden layers\n"
                 "--gemm: comma list of GEMM providers to time (tuned, clblast, kernels, host)\n"
                 "--layer: width of the hidden layer whose GEMMs are compared with the host BLAS\n"
                 "--fused-widths: comma list of layer widths for the fused-against-two-ops comparison\n"
                 "--device: OpenCL device, as nova's --device\n"
                 "--torch: auto (/usr/bin/python3, when it has torch), off, or an interpreter's path\n"
                 "--torch-threads: PyTorch's threads (0: this machine's hardware threads)\n"
                 "--torch-device: PyTorch's device, cpu or cuda (a GPU's nova beside PyTorch on the same GPU)\n";
    return 0;
  }
  const int repeats = static_cast<int>(o.integer("repeats"));
  Runtime rt(select_device(o.str("device")));
  MlpConfig c;
  c.width = static_cast<int>(o.integer("width"));
  c.depth = static_cast<int>(o.integer("depth"));
  if (c.skip >= c.depth) c.skip = -1;  // shallow networks have no skip connection
  const size_t in = kMlpInputs;
  const auto shapes = layer_shapes(c, in);
  size_t tuned_shapes = 0;
  try {
    tuned_shapes = reload_gemm_cache(rt);
  } catch (const Error& e) {
    std::cerr << "nova-bench: warning: " << e.what() << "\n";
  }
  std::cout << "device " << rt.info().name << " (" << rt.info().type_name() << "), GEMM tuning "
            << device_tuning(rt.info()).name << " + " << tuned_shapes
            << " tuned shape classes from " << gemm_tuning_cache_path()
            << "; host BLAS: " << host_blas_name() << "\n"
            << "network 63 -> " << c.depth << " x " << c.width << " (skip after layer " << c.skip
            << ") -> 4; median of " << repeats << " after a warm-up\n\n";

  std::vector<GemmProvider> providers;
  for (const std::string& name : o.strings("gemm")) providers.push_back(parse_gemm_provider(name, "--gemm"));
  std::ostringstream csv;
  csv << "gemm,batch,pass,device_samples_per_s,device_gflops,two_ops_samples_per_s,"
         "fused_over_two_ops,host_blas_samples_per_s,host_blas_gflops,device_over_host\n";
  std::cout << std::left << std::setw(8) << "batch" << std::setw(18) << "pass" << std::right
            << std::setw(14) << "samples/s" << std::setw(10) << "GFLOP/s" << std::setw(14)
            << "2-op s/s" << std::setw(12) << "fused/2-op" << std::setw(16) << "host BLAS s/s"
            << std::setw(10) << "GFLOP/s" << std::setw(10) << "ratio" << "\n";
  std::string profile;
  for (GemmProvider provider : providers) {
    set_gemm_provider(rt, provider);
    std::cout << "GEMM provider: " << gemm_provider_name(provider) << "\n";
    for (long batch_l : o.integers("batches")) {
      const size_t m = static_cast<size_t>(batch_l);
      for (bool backward : {false, true}) {
        // The network with fused dense layers (ex) and with linear + bias_act (two).
        const auto build = [&](bool fused) {
          MlpConfig cc = c;
          cc.fused_layers = fused;
          return mlp_network(rt, cc, m, backward, /*profile=*/true);
        };
        const auto fused_net = build(true), two_net = build(false);
        Executor& ex = *fused_net->ex;
        const auto run = [&](Executor& e) {
          e.forward();
          if (backward) e.backward();
          rt.finish();
        };
        const FusedTimes times =
            time_alternating(repeats, [&] { run(ex); }, [&] { run(*two_net->ex); });
        const double device_s = times.fused;
        if (backward && !profile.size()) {
          ex.reset_timings();
          ex.forward();
          ex.backward();
          profile = "per-op time, one training step at batch " + std::to_string(m) + " (" +
                    gemm_provider_name(provider) + "):\n" +
                    ex.profile_table();
        }
        const double host_s = host_blas_seconds(shapes, m, backward, repeats);
        const double flops = gemm_flops(shapes, m, backward);
        const char* pass = backward ? "forward+backward" : "forward";
        const double dev_rate = m / device_s;
        std::cout << std::left << std::setw(8) << m << std::setw(18) << pass << std::right
                  << std::fixed << std::setprecision(0) << std::setw(14) << dev_rate
                  << std::setprecision(1) << std::setw(10) << flops / device_s * 1e-9
                  << std::setprecision(0) << std::setw(14) << m / times.two_ops
                  << std::setprecision(3) << std::setw(12) << times.ratio();
        csv << gemm_provider_name(provider) << "," << m << "," << pass << "," << dev_rate << ","
            << flops / device_s * 1e-9 << "," << m / times.two_ops << "," << times.ratio() << ",";
        if (host_s > 0) {
          const double host_rate = m / host_s;
          std::cout << std::setprecision(0) << std::setw(16) << host_rate << std::setprecision(1)
                    << std::setw(10) << flops / host_s * 1e-9 << std::setprecision(3)
                    << std::setw(10) << dev_rate / host_rate << std::endl;
          csv << host_rate << "," << flops / host_s * 1e-9 << "," << dev_rate / host_rate << "\n";
        } else {  // built without a host BLAS: empty columns
          std::cout << std::setw(16) << "-" << std::setw(10) << "-" << std::setw(10) << "-"
                    << std::endl;
          csv << ",,\n";
        }
      }
    }
  }
  // The hidden w x w layer's GEMMs alone, device beside host BLAS in this run: the ratio that
  // says how close the device's GEMMs come to the host BLAS on the 256-wide layers.
  const size_t lw = static_cast<size_t>(o.integer("layer"));
  std::ostringstream layer_csv;
  layer_csv << "gemm,batch,layer,fwd_gflops,dx_gflops,dw_gflops,layer_gflops,host_fwd_gflops,"
               "host_dx_gflops,host_dw_gflops,host_layer_gflops,layer_over_host\n";
  std::cout << "\nhidden " << lw << " x " << lw
            << " layer GEMMs alone (forward X W, dX = dY W^T, dW = X^T dY), GFLOP/s:\n";
  for (GemmProvider provider : providers) {
    set_gemm_provider(rt, provider);
    for (long batch_l : o.integers("batches")) {
      const size_t m = static_cast<size_t>(batch_l);
      std::vector<std::string> configs;
      const auto dev = device_layer_seconds(rt, m, lw, repeats, configs);
      const auto host = host_layer_seconds(m, lw, repeats);
      const double one = 2.0 * m * lw * lw;
      const double dev_all = 3 * one / (dev[0] + dev[1] + dev[2]);
      const double host_all = host[0] > 0 ? 3 * one / (host[0] + host[1] + host[2]) : 0;
      std::cout << std::fixed << std::setprecision(1) << "  " << std::left << std::setw(8)
                << gemm_provider_name(provider) << std::setw(7) << m << std::right
                << " device fwd " << one / dev[0] * 1e-9 << "  dX " << one / dev[1] * 1e-9
                << "  dW " << one / dev[2] * 1e-9 << "  layer " << dev_all * 1e-9;
      layer_csv << gemm_provider_name(provider) << "," << m << "," << lw << ","
                << one / dev[0] * 1e-9 << "," << one / dev[1] * 1e-9 << ","
                << one / dev[2] * 1e-9 << "," << dev_all * 1e-9;
      if (host_all > 0) {
        std::cout << " | host BLAS fwd " << one / host[0] * 1e-9 << "  dX "
                  << one / host[1] * 1e-9 << "  dW " << one / host[2] * 1e-9 << "  layer "
                  << host_all * 1e-9 << std::setprecision(3) << " | ratio "
                  << dev_all / host_all << " (device / host BLAS)";
        layer_csv << "," << one / host[0] * 1e-9 << "," << one / host[1] * 1e-9 << ","
                  << one / host[2] * 1e-9 << "," << host_all * 1e-9 << ","
                  << dev_all / host_all << "\n";
      } else {
        layer_csv << ",,,,,\n";
      }
      std::cout << "\n    configurations: " << configs[0] << " | " << configs[1] << " | "
                << configs[2] << std::endl;
    }
  }
  // One hidden ReLU layer per width, fused (dense) against linear + bias_act, alternately.
  std::ostringstream fused_csv;
  fused_csv << "gemm,batch,width,forward_config,fwd_fused_ms,fwd_two_ops_ms,fwd_two_over_fused,"
               "step_fused_ms,step_two_ops_ms,step_two_over_fused\n";
  std::cout << "\none w -> w ReLU layer, fused (dense) against two ops (linear + bias_act), ms; "
               "ratio = two ops / fused (> 1: fusion wins):\n";
  for (GemmProvider provider : providers) {
    set_gemm_provider(rt, provider);
    for (long batch_l : o.integers("batches"))
      for (long w_l : o.integers("fused-widths")) {
        const size_t m = static_cast<size_t>(batch_l), w = static_cast<size_t>(w_l);
        const DenseLayerTimes t = time_dense_layer(rt, m, w, repeats);
        std::cout << std::fixed << "  " << std::left << std::setw(8)
                  << gemm_provider_name(provider) << std::setw(7) << m << std::setw(5) << w
                  << std::right << std::setprecision(3) << " forward " << t.forward.fused * 1e3
                  << " / " << t.forward.two_ops * 1e3 << " ratio " << t.forward.ratio()
                  << " | fwd+bwd " << t.step.fused * 1e3 << " / " << t.step.two_ops * 1e3
                  << " ratio " << t.step.ratio() << "  [" << t.config << "]" << std::endl;
        fused_csv << gemm_provider_name(provider) << "," << m << "," << w << "," << t.config
                  << "," << t.forward.fused * 1e3 << "," << t.forward.two_ops * 1e3 << ","
                  << t.forward.ratio() << "," << t.step.fused * 1e3 << ","
                  << t.step.two_ops * 1e3 << "," << t.step.ratio() << "\n";
      }
  }
  // The same network's training step beside PyTorch, with the first provider.
  set_gemm_provider(rt, providers.front());
  std::ostringstream torch_csv;
  std::cout << "\n";
  compare_with_torch(rt, c, o.integers("batches"), repeats, torch_python(o.str("torch")),
                     static_cast<int>(o.integer("torch-threads")), o.str("torch-device"), std::cout,
                     torch_csv);
  std::cout << "\n(device = the whole graph: GEMMs, bias + activation, concat, loss; host BLAS "
               "= the GEMMs alone; 2-op = the same network of linear + bias_act ops)\n\n"
            << profile << "\nCSV\n" << csv.str() << "\nCSV (layer GEMMs)\n" << layer_csv.str()
            << "\nCSV (fused dense layer)\n" << fused_csv.str()
            << "\nCSV (beside PyTorch)\n" << torch_csv.str();
  return 0;
}

}  // namespace nova::bench

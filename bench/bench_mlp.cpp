// nova-bench mlp: the reference NeRF MLP (63 -> 8 x 256, input re-fed after layer index 4,
// -> 4) at large batches: forward and forward + backward samples/s and GFLOP/s on the OpenCL
// device, the per-op time table, and the same GEMM shapes through the host BLAS in the same
// run, with the ratio. The host-BLAS column is built only with OpenBLAS (NOVA_HOST_BLAS, see
// CMakeLists.txt): a GPU machine without packages measures the device alone.
#ifdef NOVA_HOST_BLAS
#include <cblas.h>
#endif

#include <iomanip>
#include <iostream>
#include <sstream>

#include "bench.hpp"
#include "nova/executor.hpp"
#include "nova/gemm.hpp"
#include "nova/mlp.hpp"
#include "nova/ops.hpp"
#include "options.hpp"

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
#else
std::string host_blas_name() { return "not built (no OpenBLAS)"; }
double host_blas_seconds(const std::vector<LayerShape>&, size_t, bool, int) { return 0; }
#endif

}  // namespace

int mlp(const Args& args) {
  const Options o(args, {{"batches", "16384,65536"}, {"repeats", "3"}, {"device", ""},
                         {"width", "256"}, {"depth", "8"},
                         {"gemm", "clblast"}});
  if (o.help()) {
    std::cout << o.usage("nova-bench mlp");
    return 0;
  }
  const int repeats = static_cast<int>(o.integer("repeats"));
  Runtime rt(select_device(o.str("device")));
  MlpConfig c;
  c.width = static_cast<int>(o.integer("width"));
  c.depth = static_cast<int>(o.integer("depth"));
  if (c.skip >= c.depth) c.skip = -1;  // shallow networks have no skip connection
  const size_t in = 63;
  const auto shapes = layer_shapes(c, in);
  std::cout << "device " << rt.info().name << " (" << rt.info().type_name() << "), GEMM tuning "
            << gemm_tuning_for(rt.info()).name << "; host BLAS: " << host_blas_name() << "\n"
            << "network 63 -> " << c.depth << " x " << c.width << " (skip after layer " << c.skip
            << ") -> 4; median of " << repeats << " after a warm-up\n\n";

  std::vector<GemmProvider> providers;
  {
    std::stringstream list(o.str("gemm"));
    for (std::string name; std::getline(list, name, ',');) {
      if (name == "clblast") providers.push_back(GemmProvider::CLBlast);
      else if (name == "kernels") providers.push_back(GemmProvider::Kernels);
      else throw Error("--gemm: '" + name + "' is not one of clblast, kernels");
    }
  }
  std::ostringstream csv;
  csv << "gemm,batch,pass,device_samples_per_s,device_gflops,host_blas_samples_per_s,"
         "host_blas_gflops,device_over_host\n";
  std::cout << std::left << std::setw(8) << "batch" << std::setw(18) << "pass" << std::right
            << std::setw(14) << "samples/s" << std::setw(10) << "GFLOP/s" << std::setw(16)
            << "host BLAS s/s" << std::setw(10) << "GFLOP/s" << std::setw(10) << "ratio" << "\n";
  std::string profile;
  for (GemmProvider provider : providers) {
    set_gemm_provider(rt, provider);
    std::cout << "GEMM provider: " << gemm_provider_name(provider) << "\n";
    for (long batch_l : o.integers("batches")) {
      const size_t m = static_cast<size_t>(batch_l);
      for (bool backward : {false, true}) {
        Graph g;
        Tensor x = g.input("x", Shape{m, in});
        Tensor target = g.input("target", Shape{m, 4});
        Tensor y = build_mlp(x, c).output;
        if (backward)
          g.set_loss(mse(y, target));
        else
          g.keep(y);
        ExecutorOptions eo;
        eo.profile = true;
        Executor ex(rt, g, eo);
        ex.set(x, std::vector<float>(m * in, 0.1f));
        ex.set(target, std::vector<float>(m * 4, 0.5f));
        const double device_s = time_median(repeats, [&] {
          ex.forward();
          if (backward) ex.backward();
          rt.finish();
        });
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
                  << std::setprecision(1) << std::setw(10) << flops / device_s * 1e-9;
        csv << gemm_provider_name(provider) << "," << m << "," << pass << "," << dev_rate << "," << flops / device_s * 1e-9 << ",";
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
  std::cout << "\n(device = the whole graph: GEMMs, bias + activation, concat, loss; host BLAS "
               "= the GEMMs alone)\n\n"
            << profile << "\nCSV\n" << csv.str();
  return 0;
}

}  // namespace nova::bench

// `nova tune`: searches GEMM configurations for the shapes nova's MLPs run on this device,
// checks every candidate against a float64 host reference, and writes the winners to the
// per-device tuning cache that configure_gemm reads at start-up. The search and the cache are
// the tuning module's (gemm_tuning.hpp); the GEMM op runs the candidates (gemm_runner).
#ifdef NOVA_HOST_BLAS
#include <cblas.h>
#endif

#include <algorithm>
#include <chrono>
#include <iomanip>
#include <iostream>
#include <set>
#include <sstream>

#include "cli/options.hpp"
#include "nova/ops/linalg/gemm.hpp"
#include "nova/tuning/gemm_tuning.hpp"
#include "nova/runtime/runtime.hpp"
#include "runtime/parse_number.hpp"

namespace nova::cli {
namespace {

std::vector<size_t> size_list(const std::string& text, const char* option) {
  std::vector<size_t> out;
  std::stringstream s(text);
  for (std::string item; std::getline(s, item, ',');) {
    const std::optional<long> v = parse_whole_long(item);
    if (!v || *v <= 0) throw Error(std::string("--") + option + ": '" + item + "' is not a positive integer");
    out.push_back(static_cast<size_t>(*v));
  }
  if (out.empty()) throw Error(std::string("--") + option + " is empty");
  return out;
}

// The GEMMs of an MLP of hidden width w on input width in (the reference layout: 8 layers, the
// input re-fed once, a 4-wide head): forward X W (nn), input gradient dY W^T (nt; not for the
// first layer) and weight gradient X^T dY (tn). `quick`: the w x w layer only.
std::vector<GemmShapeClass> mlp_shapes(size_t rows, size_t w, size_t in, bool quick) {
  std::vector<std::pair<size_t, size_t>> layers;  // (k, n)
  if (!quick) layers.push_back({in, w});
  layers.push_back({w, w});
  if (!quick) {
    layers.push_back({in + w, w});
    layers.push_back({w, 4});
  }
  std::vector<GemmShapeClass> s;
  for (const auto& [k, n] : layers) {
    GemmArgs nn{false, false, rows, n, k};
    s.push_back(*gemm_shape_class(nn));
    if (k != in) s.push_back(*gemm_shape_class(GemmArgs{false, true, rows, k, n}));
    s.push_back(*gemm_shape_class(GemmArgs{true, false, k, n, rows}));
  }
  return s;
}

#ifdef NOVA_HOST_BLAS
double host_blas_gflops(const GemmShapeClass& s) {
  const bool ta = s.kind == "tn", tb = s.kind == "nt";
  const int m = static_cast<int>(s.m), n = static_cast<int>(s.n), k = static_cast<int>(s.k);
  std::vector<float> a(s.m * s.k, 0.5f), b(s.k * s.n, 0.25f), c(s.m * s.n);
  auto once = [&] {
    cblas_sgemm(CblasRowMajor, ta ? CblasTrans : CblasNoTrans, tb ? CblasTrans : CblasNoTrans, m,
                n, k, 1.0f, a.data(), ta ? m : k, b.data(), tb ? k : n, 0.0f, c.data(), n);
  };
  once();
  std::vector<double> t;
  for (int r = 0; r < 3; ++r) {
    const auto a0 = std::chrono::steady_clock::now();
    once();
    t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - a0).count());
  }
  std::sort(t.begin(), t.end());
  return 2.0 * s.m * s.n * s.k / t[1] * 1e-9;
}
constexpr bool kHostBlas = true;
#else
double host_blas_gflops(const GemmShapeClass&) { return 0; }
constexpr bool kHostBlas = false;
#endif

}  // namespace

int tune(const Args& args) {
  po::options_description desc("nova tune options");
  add_common_options(desc);
  desc.add_options()("quick", po::bool_switch(),
                     "fewer candidates and only the hidden w x w layer's three GEMMs")(
      "out", po::value<std::string>()->default_value(""),
      "cache file to update (default: $NOVA_TUNING_CACHE, else "
      "$XDG_CACHE_HOME/nova/gemm-tuning.tsv, else ~/.cache/nova/gemm-tuning.tsv)")(
      "batch", po::value<std::string>()->default_value("16384"),
      "sample counts (the GEMMs' long dimension) to tune at, comma-separated; each tuned class "
      "serves counts within a factor of 4")(
      "widths", po::value<std::string>()->default_value("256"),
      "hidden widths of the MLPs, comma-separated")(
      "inputs", po::value<std::string>()->default_value("63"),
      "input (encoding) widths, comma-separated: 63 = xyz with L=10")(
      "repeats", po::value<int>()->default_value(3), "timed runs per candidate (median)")(
      "budget", po::value<double>()->default_value(90),
      "seconds per shape after which remaining candidates are skipped")(
      "dry-run", po::bool_switch(), "search and print, but write no cache");
  po::variables_map vm;
  if (!parse(args, desc, vm,
             "usage: nova tune [--device SEL] [--quick] [--out FILE] [--batch N,...] "
             "[--widths W,...] [--inputs I,...]\n\n"
             "Times CLBlast parameter sets, nova's own GEMM kernels and register-blocked "
             "variants on the MLP GEMM shapes, checks each against a float64 host reference, "
             "and stores the fastest per shape in the tuning cache read at start-up."))
    return 0;
  const bool quick = vm["quick"].as<bool>();
  std::string path = vm["out"].as<std::string>();
  if (path.empty()) path = gemm_tuning_cache_path();
  if (path.empty() && !vm["dry-run"].as<bool>())
    throw Error("no cache path: pass --out FILE or set NOVA_TUNING_CACHE");
  const int repeats = vm["repeats"].as<int>();
  if (repeats < 1) throw Error("--repeats must be at least 1");

  std::set<GemmShapeClass> seen;
  std::vector<GemmShapeClass> shapes;
  for (size_t rows : size_list(vm["batch"].as<std::string>(), "batch")) {
    if (rows < kGemmTunedMinRows)
      throw Error("--batch " + std::to_string(rows) + ": shorter than " +
                  std::to_string(kGemmTunedMinRows) + " rows, such GEMMs are not tuned");
    for (size_t w : size_list(vm["widths"].as<std::string>(), "widths"))
      for (size_t in : size_list(vm["inputs"].as<std::string>(), "inputs"))
        for (const auto& s : mlp_shapes(rows, w, in, quick))
          if (seen.insert(s).second) shapes.push_back(s);
  }

  Runtime rt(select_device(vm["device"].as<std::string>()));
  configure_gemm(rt);
  std::cout << "nova tune: device " << rt.info().name << " (" << rt.info().vendor << ", driver "
            << rt.info().driver_version << "), CLBlast " << clblast_version() << "\n"
            << shapes.size() << " shape classes" << (quick ? " (quick)" : "")
            << "; cache: " << (vm["dry-run"].as<bool>() ? "not written (--dry-run)" : path)
            << "\n(a cold PoCL cache compiles each CLBlast parameter set once: 10-35 s each)\n"
            << std::flush;

  GemmSearchOptions so;
  so.repeats = repeats;
  so.max_seconds = vm["budget"].as<double>();
  so.progress = [](const std::string& line) { std::cout << line << std::endl; };
  const GemmRunner runner = gemm_runner();
  std::vector<GemmSearchResult> results;
  std::vector<double> host;
  std::vector<GemmCacheEntry> entries;
  const auto t0 = std::chrono::steady_clock::now();
  for (size_t i = 0; i < shapes.size(); ++i) {
    std::cout << "[" << i + 1 << "/" << shapes.size() << "] " << shapes[i].str() << std::endl;
    auto r = search_gemm(rt, shapes[i], gemm_candidates(rt, shapes[i], quick, host_gemm_available(rt)),
                         runner, so);
    host.push_back(host_blas_gflops(shapes[i]));
    if (r.winner >= 0) {
      GemmCacheEntry e = gemm_cache_key(rt.info());
      e.shape = r.shape;
      e.config = r.config;
      e.default_gflops = r.default_gflops;
      e.tuned_gflops = r.tuned_gflops;
      entries.push_back(e);
    } else {
      std::cout << "  no candidate passed the reference check: the table's CLBlast stays\n";
    }
    results.push_back(std::move(r));
  }
  const double secs =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  std::cout << "\n" << std::left << std::setw(22) << "shape (kind MxNxK)" << std::right
            << std::setw(10) << "default" << std::setw(10) << "tuned" << std::setw(8) << "x"
            << std::setw(11) << "host BLAS" << std::setw(12) << "tuned/host" << "  winner\n";
  for (size_t i = 0; i < results.size(); ++i) {
    const auto& r = results[i];
    std::cout << std::left << std::setw(22) << r.shape.str() << std::right << std::fixed
              << std::setprecision(1) << std::setw(10) << r.default_gflops << std::setw(10)
              << r.tuned_gflops << std::setprecision(2) << std::setw(8)
              << (r.default_gflops > 0 ? r.tuned_gflops / r.default_gflops : 0.0);
    if (kHostBlas)
      std::cout << std::setprecision(1) << std::setw(11) << host[i] << std::setprecision(2)
                << std::setw(12) << r.tuned_gflops / host[i];
    else
      std::cout << std::setw(11) << "-" << std::setw(12) << "-";
    std::cout << "  " << (r.winner >= 0 ? r.config.str() : "none") << "\n";
  }
  std::cout << "(GFLOP/s; default = the built-in table's CLBlast; host BLAS = "
            << (kHostBlas ? "OpenBLAS, same shapes, same run" : "not built (no OpenBLAS)")
            << "); " << std::setprecision(0) << secs << " s\n";
  if (kHostBlas && std::any_of(results.begin(), results.end(), [](const auto& r) { return r.winner >= 0 && r.config.str() == "host"; }))
    std::cout << "(winner host: the host BLAS called on the device's buffers, as training calls it; "
                 "tuned/host is then that path's cost against the bare call)\n";
  if (!vm["dry-run"].as<bool>()) {
    merge_gemm_cache(path, entries);
    std::cout << "wrote " << entries.size() << " winners to " << path << "\n";
  }
  return 0;
}

}  // namespace nova::cli

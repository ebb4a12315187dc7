#include <algorithm>
#include <chrono>
#include <cstring>
#include <exception>
#include <iostream>
#include <string>

#include <unistd.h>

#include "bench.hpp"
#include "nova/runtime/error.hpp"

namespace nova::bench {

const std::vector<Benchmark>& benchmarks() {
  static const std::vector<Benchmark> all = {
      {"mlp", "reference MLP forward / forward+backward, GEMMs beside a host BLAS", mlp},
      {"render", "compositing op forward / backward for 1 + K NeRFs beside a host loop", render},
      {"ops", "every op of the op table (tests/op_table.hpp): ms forward, ms forward+backward, GFLOP/s", ops},
#ifdef NOVA_BENCH_IO
      {"tradeoff", "trains a scene under several settings: PSNR against training time (CSV, PNG, speedup)", tradeoff},
      {"accuracy", "trains and evaluates a list of scenes (sets dev, test, real) with one configuration: PSNR / SSIM / time per scene and set (table, CSV, JSON, PNG)", accuracy},
      {"devices", "every OpenCL device side by side: MLP speed and error against float64, a short training's speed and PSNR (table, CSV, JSON, PNG)", devices},
      {"step", "training steps per preset, phase and object count: s/step, rays/s, device memory, peak RSS, per-op tables", step},
      {"masks", "nova masks against known masks (the synthetic family's exact ones, a scene's own): IoU per frame", masks},
      {"motion", "the rigid objects' starting motion (frame-to-frame alignment) against the synthetic family's exact poses: turn error per frame, drift", motion},
      {"view", "renders a trained run's views with early ray termination on and off: time ratio, evaluations saved", view},
#endif
  };
  return all;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

double time_median(int repeats, const std::function<void()>& fn) {
  fn();
  std::vector<double> t;
  for (int i = 0; i < repeats; ++i) {
    const auto a = std::chrono::steady_clock::now();
    fn();
    t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count());
  }
  return median(t);
}

ScratchDir::ScratchDir(const std::string& what)
    : path_(std::filesystem::temp_directory_path() / ("nova-bench-" + what + "-" + std::to_string(::getpid()))) {
  std::filesystem::create_directories(path_);
}

ScratchDir::~ScratchDir() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

}  // namespace nova::bench

int main(int argc, char** argv) {
  const auto& all = nova::bench::benchmarks();
  if (argc < 2 || !std::strcmp(argv[1], "--help")) {
    std::cout << "usage: nova-bench <benchmark> [options]\n\nbenchmarks:\n";
    for (const auto& b : all) std::cout << "  " << b.name << "\t" << b.summary << "\n";
    return argc < 2 ? nova::kExitUsage : 0;
  }
  for (const auto& b : all)
    if (b.name == std::string(argv[1])) {
      try {
        return b.run(nova::bench::Args(argv + 2, argv + argc));
      } catch (const nova::Error& e) {
        std::cerr << "nova-bench " << b.name << ": error: " << e.what() << "\n";
        return e.exit_code();
      } catch (const std::exception& e) {
        std::cerr << "nova-bench " << b.name << ": error: " << e.what() << "\n";
        return nova::kExitInternal;
      }
    }
  std::cerr << "nova-bench: unknown benchmark '" << argv[1] << "'\n";
  return nova::kExitUsage;
}

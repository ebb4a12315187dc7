// `nova train-mlp`: fits the reference MLP to a smooth 3D function and reports the loss fall,
// throughput and memory plan; --profile adds the per-op time table.
#include <iomanip>
#include <iostream>

#include "cli/options.hpp"
#include "nova/train/mlp_fit.hpp"
#include "nova/runtime/runtime.hpp"

namespace nova::cli {

int train_mlp(const Args& args) {
  MlpFitConfig c;
  po::options_description desc("nova train-mlp options");
  add_common_options(desc);
  desc.add_options()
      ("depth", po::value<int>(&c.mlp.depth)->default_value(8), "hidden layers")
      ("width", po::value<int>(&c.mlp.width)->default_value(256), "hidden width")
      ("skip", po::value<int>(&c.mlp.skip)->default_value(4), "layer whose output gets the input re-concatenated (-1: none)")
      ("frequencies", po::value<int>(&c.frequencies)->default_value(10), "positional-encoding frequencies L")
      ("batch", po::value<size_t>(&c.batch)->default_value(1024), "points per step")
      ("steps", po::value<int>(&c.steps)->default_value(200), "Adam steps")
      ("lr", po::value<float>(&c.lr)->default_value(5e-4f), "learning rate")
      ("seed", po::value<unsigned>(&c.seed)->default_value(1), "random seed")
      ("profile", po::bool_switch(&c.profile), "print per-op times (OpenCL profiling events)");
  po::variables_map vm;
  if (!parse(args, desc, vm, "usage: nova train-mlp [options]")) return 0;
  if (c.batch == 0 || c.steps <= 0 || !(c.lr > 0))
    throw Error("--batch, --steps and --lr must be positive");

  Runtime rt(select_device(vm["device"].as<std::string>()));
  std::cout << "device " << rt.info().id() << ": " << rt.info().name << "\n";
  const auto r = fit_smooth_function(rt, c, [&](int step, float loss, double s) {
    const double rate = (step + 1) * static_cast<double>(c.batch) / s;
    std::cout << "step " << std::setw(5) << step + 1 << "/" << c.steps << "  loss "
              << std::scientific << std::setprecision(3) << loss << std::defaultfloat
              << "  " << std::fixed << std::setprecision(0) << rate << " samples/s  ETA "
              << std::setprecision(1) << s / (step + 1) * (c.steps - step - 1) << " s"
              << std::defaultfloat << std::endl;
  });
  std::cout << std::setprecision(4) << "held-out loss " << r.initial_loss << " -> "
            << r.final_loss << " (" << std::setprecision(1) << std::fixed
            << r.initial_loss / r.final_loss << "x lower) in " << r.seconds << " s, "
            << std::setprecision(0) << r.samples_per_second << " samples/s\n"
            << r.parameters << " parameters; activation arena " << (r.arena_bytes >> 10)
            << " KiB planned vs " << (r.unplanned_bytes >> 10) << " KiB unplanned\n";
  if (c.profile) std::cout << "\n" << r.profile;
  return 0;
}

}  // namespace nova::cli

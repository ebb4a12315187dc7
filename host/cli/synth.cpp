// `nova synth --out DIR`: write a ray-traced synthetic NOVA scene with ground truth.
#include <chrono>
#include <iostream>

#include "cli/options.hpp"
#include "cli/run_setup.hpp"
#include "nova/runtime/error.hpp"
#include "nova/data/synth.hpp"

namespace nova::cli {

int synth(const Args& args) {
  po::options_description desc("nova synth options");
  desc.add_options()("help,h", "show this help")(
      "out", po::value<std::string>()->required(), "output folder (must not exist)")(
      "preset", po::value<std::string>()->default_value("default"),
      "tiny (tests: 10 frames, 64x48) | default (demo: 24 frames, 160x120) | family (the "
      "seed draws a whole scene: 1-3 objects, shapes, motion, camera path, size, "
      "imperfect training inputs) | deforming (the family's scene of the seed, its objects "
      "also squashing and stretching)")(
      "seed", po::value<long long>()->default_value(0), "seed in [0, 4294967295]: same seed, same bytes")(
      "force", po::bool_switch(), "replace an existing output folder");
  po::variables_map vm;
  if (!parse(args, desc, vm,
             "usage: nova synth --out DIR [--preset tiny|default|family|deforming] [--seed S] [--force]"))
    return 0;
  const long long seed = vm["seed"].as<long long>();
  if (seed < 0 || seed > 4294967295LL) throw Error("--seed " + std::to_string(seed) + " is outside [0, 4294967295]");
  check_output_location(vm["out"].as<std::string>(), "--out");
  const auto t0 = std::chrono::steady_clock::now();
  const std::string report =
      write_synthetic_scene(vm["out"].as<std::string>(), vm["preset"].as<std::string>(),
                            static_cast<uint32_t>(seed), vm["force"].as<bool>());
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cout << report << " in " << secs << " s\n";
  return 0;
}

}  // namespace nova::cli

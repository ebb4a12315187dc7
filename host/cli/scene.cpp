// `nova scene --scene DIR`: load a scene with the readers of host/data, print its summary and
// how long loading took.
#include <chrono>
#include <iostream>

#include "cli/options.hpp"
#include "nova/data/scene_io.hpp"

namespace nova::cli {

int scene(const Args& args) {
  po::options_description desc("nova scene options");
  desc.add_options()("help,h", "show this help")(
      "scene", po::value<std::string>()->required(), "scene folder")(
      "format", po::value<std::string>()->default_value("auto"), "auto | nova | llff | blender | npz")(
      "factor", po::value<int>()->default_value(0),
      "image downscale factor (0: images/ if present, else the one images_F/)")(
      "static-only", po::bool_switch(), "load a scene without motion masks as static-only (K = 0)")(
      "split", po::value<std::string>()->default_value("train"), "Blender: transforms_<split>.json; npz: train, val or test");
  po::variables_map vm;
  if (!parse(args, desc, vm, "usage: nova scene --scene DIR [--factor F] [--static-only] [--format auto|nova|llff|blender|npz] [--split S]"))
    return 0;
  LoadOptions opt;
  opt.format = vm["format"].as<std::string>();
  opt.factor = vm["factor"].as<int>();
  opt.static_only = vm["static-only"].as<bool>();
  opt.split = vm["split"].as<std::string>();
  const auto t0 = std::chrono::steady_clock::now();
  const Scene s = load_scene(vm["scene"].as<std::string>(), opt);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cout << scene_summary(s) << "  load time   " << secs << " s\n";
  return 0;
}

}  // namespace nova::cli

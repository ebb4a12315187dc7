// `nova masks --scene DIR`: the motion masks of a video from its frames, poses and disparity
// (include/nova/masks/motion_masks.hpp), written as the scene's motion_masks/ folder.
#include <chrono>
#include <filesystem>
#include <iostream>

#include "cli/options.hpp"
#include "cli/run_setup.hpp"
#include "nova/masks/motion_masks.hpp"
#include "nova/data/scene_io.hpp"

namespace nova::cli {

int masks(const Args& args) {
  po::options_description desc("nova masks options");
  desc.add_options()("help,h", "show this help")(
      "scene", po::value<std::string>()->required(), "NOVA scene folder: images/, poses_bounds.npy, disp/")(
      "objects", po::value<std::string>()->default_value("auto"),
      "K: at most K objects (smaller moving regions join the nearest), or auto: as many as are found")(
      "out", po::value<std::string>()->default_value(""), "output folder (default: SCENE/motion_masks)")(
      "factor", po::value<int>()->default_value(0),
      "image downscale factor (0: images/ if present, else the one images_F/); masks of another size "
      "are resized when the scene is loaded")(
      "no-grabcut", po::bool_switch(), "keep the thresholded score's edges (no GrabCut refinement)")(
      "force", po::bool_switch(), "replace an existing output folder");
  po::variables_map vm;
  if (!parse(args, desc, vm,
             "usage: nova masks --scene DIR [--objects K|auto] [--out DIR] [--factor F] [--no-grabcut] [--force]"))
    return 0;
  namespace fs = std::filesystem;
  const std::string dir = vm["scene"].as<std::string>();
  if (!fs::is_directory(dir)) throw Error(dir + ": not a folder");
  if (!fs::exists(fs::path(dir) / "poses_bounds.npy"))
    throw Error((fs::path(dir) / "poses_bounds.npy").string() + ": missing; nova masks needs the camera poses (N x 17, "
                "LLFF's poses_bounds.npy, e.g. from COLMAP)");
  if (!fs::is_directory(fs::path(dir) / "disp"))
    throw Error((fs::path(dir) / "disp").string() + ": missing; nova masks needs a disparity map per frame "
                "(disp/NNN.npy, e.g. from a monocular depth network)");
  MotionMaskOptions opt;
  const std::string objects = vm["objects"].as<std::string>();
  if (objects != "auto") {
    try {
      size_t used = 0;
      opt.objects = std::stoi(objects, &used);
      if (used != objects.size() || opt.objects < 1) throw std::invalid_argument(objects);
    } catch (const std::exception&) {
      throw Error("--objects '" + objects + "': expected a number of objects >= 1, or auto");
    }
  }
  opt.grabcut = !vm["no-grabcut"].as<bool>();
  std::string out = vm["out"].as<std::string>();
  if (out.empty()) out = (fs::path(dir) / "motion_masks").string();
  check_output_location(out, "--out");
  if (fs::exists(out) && !vm["force"].as<bool>())
    throw Error(out + ": already exists (choose another --out, or pass --force to replace it)");

  const auto t0 = std::chrono::steady_clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  LoadOptions load;
  load.format = "nova";
  load.static_only = true;  // existing masks are not read
  load.load_gt = false;
  load.factor = vm["factor"].as<int>();
  const Scene scene = load_scene(dir, load);
  std::cout << "nova masks: " << scene.frames.size() << " frames at " << scene.frames[0].rgb.width << "x"
            << scene.frames[0].rgb.height << " loaded (" << seconds() << " s)" << std::endl;
  opt.progress = [](const std::string& line) { std::cout << "  " << line << std::endl; };
  const MotionMasks m = make_motion_masks(scene, opt);
  write_motion_masks(scene, m, out, vm["force"].as<bool>());
  for (const auto& line : m.notes)
    if (line.rfind("nothing moves", 0) == 0 || line.rfind("--objects", 0) == 0) std::cout << line << "\n";
  std::cout << "nova masks: " << (m.nothing_moves ? "nothing moves; wrote an all-background mask set" : std::to_string(m.objects()) + " object(s)")
            << " in " << out << " (check pictures in " << (fs::path(out) / "check").string() << ") in " << seconds()
            << " s" << std::endl;
  return 0;
}

}  // namespace nova::cli

// `nova render --run RUN --out DIR`: renders a trained run. Without --compose: one camera
// (a frame's camera, held-out frames included, or --pose) at one time or at every frame's time, writing colour,
// depth and per-NeRF masks as PNG frames (and an MP4 with --video). With --compose SPEC:
// every target of a composition spec (io/compose_spec_text.hpp), hard-blended (add_blend_options).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>
#include <vector>

#include "cli/mpi_job.hpp"
#include "cli/options.hpp"
#include "cli/render_progress.hpp"
#include "cli/run_setup.hpp"
#include "nova/sampling/camera.hpp"
#include "nova/io/compose_spec_text.hpp"
#include "nova/eval/evaluation.hpp"
#include "nova/io/image_io.hpp"
#include "nova/io/pictures.hpp"
#include "nova/io/video.hpp"
#include "nova/runtime/runtime.hpp"

namespace nova::cli {
namespace {

// 12 numbers separated by spaces or commas, in one argument or several; the 3x3 part must be
// a rotation (rays are built from its columns as unit axes).
Camera parse_pose(const std::vector<std::string>& words, Camera base) {
  std::string text;
  for (const std::string& w : words) text += (text.empty() ? "" : " ") + w;
  std::string spaced = text;
  for (char& ch : spaced)
    if (ch == ',') ch = ' ';
  std::istringstream in(spaced);
  std::vector<double> m;
  for (std::string word; in >> word;) {
    char* end = nullptr;
    const double x = std::strtod(word.c_str(), &end);
    if (end == word.c_str() || *end != '\0') throw Error("--pose: '" + word + "' in '" + text + "' is not a number");
    if (!std::isfinite(x)) throw Error("--pose: '" + word + "' in '" + text + "' is not finite");
    m.push_back(x);
  }
  if (m.size() != 12)
    throw Error("--pose: expected 12 numbers (the 3x4 camera-to-world matrix, row-major), got " +
                std::to_string(m.size()) + " in '" + text + "'");
  // Columns orthonormal to 1e-3 (six printed digits pass) and a right-handed frame.
  const double worst = axes_deviation(m.data(), 4);
  const auto at = [&](int r, int c) { return m[static_cast<size_t>(r * 4 + c)]; };
  const double det = at(0, 0) * (at(1, 1) * at(2, 2) - at(1, 2) * at(2, 1)) -
                     at(0, 1) * (at(1, 0) * at(2, 2) - at(1, 2) * at(2, 0)) +
                     at(0, 2) * (at(1, 0) * at(2, 1) - at(1, 1) * at(2, 0));
  if (worst > 1e-3 || det < 0)
    throw Error("--pose: the 3x3 part of '" + text + "' is not a rotation (orthonormal columns, determinant +1)");
  std::copy(m.begin(), m.end(), base.c2w.begin());
  return base;
}

// Whether `word` is one or more numbers separated by commas ("-1", "0,-1,", "1,0").
bool numbers_word(const std::string& word) {
  bool any = false;
  std::istringstream parts(word);
  for (std::string part; std::getline(parts, part, ',');) {
    if (part.empty()) continue;
    char* end = nullptr;
    std::strtod(part.c_str(), &end);
    if (end == part.c_str() || *end != '\0') return false;
    any = true;
  }
  return any;
}

// The words after --pose that are numbers (or comma lists of them) joined into one argument,
// so that a pose typed as several words may hold negative numbers, which the option parser
// would take for options.
Args join_pose_words(const Args& args) {
  Args out;
  for (size_t i = 0; i < args.size(); ++i) {
    out.push_back(args[i]);
    if (args[i] != "--pose") continue;
    std::string joined;
    for (; i + 1 < args.size() && numbers_word(args[i + 1]); ++i) joined += (joined.empty() ? "" : " ") + args[i + 1];
    if (!joined.empty()) out.push_back(joined);
  }
  return out;
}

// A number as the user would write it (no trailing zeros).
std::string vm_text(double x) {
  std::ostringstream o;
  o << x;
  return o.str();
}

std::string frame_name(size_t i) {
  char b[32];
  std::snprintf(b, sizeof b, "%03zu.png", i);
  return b;
}

// Writes the colour, depth and masks of one view as <stem>.png, <stem>_depth.png and
// <stem>_mask<k>.png (k = 0 background, then the instances).
Image8 write_view(const ViewImage& v, const std::string& dir, const std::string& stem, bool masks) {
  Image8 rgb = float_rgb_to_image(v.rgb, v.width, v.height);
  write_png(dir + "/" + stem + ".png", rgb);
  const DepthRange d = robust_depth_range(v.depth);
  write_png(dir + "/" + stem + "_depth.png", depth_to_color(v.depth, v.width, v.height, d.lo, d.hi));
  if (masks)
    for (size_t k = 0; k < v.masks.size(); ++k)
      write_png(dir + "/" + stem + "_mask" + std::to_string(k) + ".png", float_to_gray(v.masks[k], v.width, v.height));
  return rgb;
}

// "target NAME: instance 3 (object 2, t=0.5) pivot (x, y, z) from density" (n 0-based).
std::string describe_pivot(const std::string& target, size_t n, const ComposeInstance& i, const InstancePivot& pv) {
  char b[160];
  std::snprintf(b, sizeof b, "instance %zu (object %d, t=%g) pivot (%.6g, %.6g, %.6g) from %s", n + 1, i.object,
                i.time, pv.pivot[0], pv.pivot[1], pv.pivot[2], pivot_source_name(pv.from));
  return "target " + target + ": " + b;
}

}  // namespace

// The command on one process, or as one rank of an MPI job (`mpi`): the frames of a view
// sequence are dealt out round-robin and written into rank 0's staging folder; rank 0 renders
// the composition targets, assembles the video and commits the folder.
int render_rank(const Args& args, MpiJob* mpi) {
  const bool lead = !mpi || mpi->rank() == 0;
  po::options_description desc("nova render options");
  add_common_options(desc);
  desc.add_options()("run", po::value<std::string>()->required(), "trained run folder")(
      "out", po::value<std::string>()->required(), "output folder (must not exist unless --force)")(
      "scene", po::value<std::string>()->default_value(""), "scene folder (default: the run's)")(
      "camera", po::value<int>()->default_value(0), "camera of frame I of the scene (held-out frames count) to render from")(
      "pose", po::value<std::vector<std::string>>(),
      "12 numbers (spaces or commas): a camera-to-world 3x4 matrix, row-major, in scene coordinates, instead of --camera")(
      "time", po::value<double>(), "object time in [-1, 1] (frame i of N has 2i/N - 1); default: every frame's time")(
      "compose", po::value<std::string>(), "composition spec: render each of its targets (see docs/rendering.md)")(
      "video", po::bool_switch(), "also write video.mp4 of the colour frames")(
      "fps", po::value<double>()->default_value(10.0), "frame rate of the video")(
      "no-masks", po::bool_switch(), "skip the per-NeRF mask PNGs")(
      "force", po::bool_switch(), "replace an existing output folder");
  add_blend_options(desc);
  po::variables_map vm;
  if (!parse(join_pose_words(args), desc, vm, "usage: nova render --run RUN --out DIR [--camera I | --pose M] [--time T] [--compose SPEC] [--video]"))
    return 0;
  // Everything the options alone decide is refused before any work.
  check_output_location(vm["out"].as<std::string>(), "--out");
  const bool video = vm["video"].as<bool>();
  if (vm.count("compose")) {
    for (const char* o : {"camera", "pose", "time"})
      if (vm.count(o) && !vm[o].defaulted())
        throw Error("--" + std::string(o) + " does not apply to --compose (each target names its camera and times)");
  }
  if (vm.count("pose") && vm["pose"].as<std::vector<std::string>>().size() > 1)
    throw Error("--pose is given more than once: pass one camera");
  if (vm.count("pose") && !vm["camera"].defaulted()) throw Error("--camera and --pose both give the camera: pass one");
  if (!vm["fps"].defaulted() && !video) throw Error("--fps sets the video's frame rate: it needs --video");
  const double fps = vm["fps"].as<double>();
  if (video && !(std::isfinite(fps) && fps > 0)) throw Error("--fps " + vm_text(fps) + ": the frame rate must be positive");
  if (vm.count("time")) {
    const double t = vm["time"].as<double>();
    if (!(t >= -1.0 && t <= 1.0)) throw Error("--time " + vm_text(t) + " is outside [-1, 1]");
  }
  const auto t0 = std::chrono::steady_clock::now();
  OpenRun run = open_run(vm["run"].as<std::string>(), vm["scene"].as<std::string>(), false);
  const Scene& scene = run.scene;
  const std::vector<FolderFrame> all_frames = folder_frames(scene);
  const std::string frame_range = "0.." + std::to_string(all_frames.size() - 1);
  const bool masks = !vm["no-masks"].as<bool>();
  const BlendChoice blend = blend_choice(vm);
  ComposeSpec spec;
  if (vm.count("compose")) {
    spec = read_compose_spec(vm["compose"].as<std::string>());
    for (const ComposeTarget& t : spec.targets) {
      if (t.camera < 0 || t.camera >= static_cast<int>(all_frames.size()))
        throw Error("compose spec '" + vm["compose"].as<std::string>() + "', target '" + t.name + "': camera " +
                    std::to_string(t.camera) + " is not a frame of the scene (" + frame_range + ")");
      for (const ComposeInstance& i : t.instances)
        if (i.object < 1 || i.object > scene.num_objects)
          throw Error("compose spec '" + vm["compose"].as<std::string>() + "', target '" + t.name + "': object " +
                      std::to_string(i.object) + " does not exist (the run has " + std::to_string(scene.num_objects) +
                      " object NeRF(s))");
    }
  }
  if (vm["video"].as<bool>() && !video_supported())
    throw Error("--video: this nova was built without OpenCV's videoio, so it writes no videos "
                "(install libopencv-videoio-dev and rebuild; the frames are PNGs either way)");
  const int cam = vm["camera"].as<int>();
  if (cam < 0 || cam >= static_cast<int>(all_frames.size()))
    throw Error("--camera " + std::to_string(cam) + ": the scene has frames " + frame_range);
  Camera camera = all_frames[static_cast<size_t>(cam)].camera;
  if (vm.count("pose")) camera = parse_pose(vm["pose"].as<std::vector<std::string>>(), camera);

  const DeviceInfo device = mpi ? rank_device(vm["device"].as<std::string>()) : select_device(vm["device"].as<std::string>());
  Runtime rt(device, false);
  ViewRenderer renderer(rt, run.files.config, run.geometry, run.files.checkpoint);
  RenderProgress progress;
  if (lead) renderer.set_progress([&](size_t done, size_t total) { progress(done, total); });
  // Rank 0 owns the staging folder; the other ranks write into it once it exists.
  std::unique_ptr<StagedFolder> staged;
  if (lead) staged = std::make_unique<StagedFolder>(vm["out"].as<std::string>(), vm["force"].as<bool>());
  if (mpi) mpi->barrier();
  const std::string staging = staged ? staged->path() : StagedFolder::staging_path(vm["out"].as<std::string>());
  std::vector<Image8> frames;
  size_t views = 0;
  if (!spec.empty() && !lead) {
    // The composition targets are few: rank 0 renders them.
  } else if (!spec.empty()) {
    for (const ComposeTarget& t : spec.targets) {
      ViewRequest req;
      req.camera = all_frames[static_cast<size_t>(t.camera)].camera;
      req.background = t.background;
      req.hard_blend = blend.composition;
      for (size_t n = 0; n < t.instances.size(); ++n) {
        const ComposeInstance& i = t.instances[n];
        const InstancePivot pv = renderer.pivot_for(i);
        std::cout << describe_pivot(t.name, n, i, pv) << "\n";
        if (pv.from == InstancePivot::From::Origin)
          std::cerr << "warning: target " << t.name << ", instance " << n + 1 << ": object " << i.object
                    << " has no density at t=" << i.time << "; it turns about the scene origin\n";
        req.instances.push_back(placed_instance(i, pv.pivot));
      }
      progress.start(t.name);
      frames.push_back(write_view(renderer.render(req), staging, t.name, masks));
      std::cerr << "rendered " << t.name << " (" << t.instances.size() << " instances)\n";
      ++views;
    }
  } else {
    std::vector<double> times;
    if (vm.count("time")) {
      times.push_back(vm["time"].as<double>());
    } else {
      for (const FolderFrame& f : all_frames) times.push_back(f.time);
    }
    // Rank 0 counts its own frames (every N-th of an MPI job's).
    const size_t ranks = mpi ? static_cast<size_t>(mpi->size()) : 1;
    const size_t own = (times.size() + ranks - 1) / ranks;
    for (size_t i = 0; i < times.size(); ++i) {
      if (mpi && static_cast<int>(i % ranks) != mpi->rank()) continue;
      ViewRequest req;
      req.camera = camera;
      req.hard_blend = blend.scene_views;
      req.instances = scene_instances(scene.num_objects, times[i]);
      progress.start("view " + std::to_string(i + 1) + "/" + std::to_string(times.size()));
      frames.push_back(write_view(renderer.render(req), staging, frame_name(i).substr(0, 3), masks));
      if (lead) count_progress(mpi ? "rendered (rank 0's frames)" : "rendered", i / ranks + 1, own);
      ++views;
    }
    if (mpi) {  // every frame on disk; rank 0 takes them back in order for the video
      mpi->barrier();
      views = times.size();
      if (lead) {
        frames.clear();
        for (size_t i = 0; i < times.size(); ++i) frames.push_back(read_rgb(staging + "/" + frame_name(i).substr(0, 3) + ".png"));
      }
    }
  }
  if (!lead) return 0;
  if (video) write_video(frames, staging + "/video.mp4", fps);
  staged->commit();
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cout << "rendered " << views << " view(s) into " << vm["out"].as<std::string>() << " in " << secs << " s\n";
  return 0;
}

int render(const Args& args) { return run_as_ranks("render", args, render_rank); }

}  // namespace nova::cli

// `nova eval --run RUN`: renders the scene's ground-truth views with the trained run and
// reports PSNR (OpenCV's number on 8-bit images) and SSIM per view, their means, and for
// synthetic scenes the composition targets; writes RUN/eval.json and the renders as PNGs.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "cli/mpi_job.hpp"
#include "cli/options.hpp"
#include "cli/render_progress.hpp"
#include "cli/run_setup.hpp"
#include "nova/evaluation.hpp"
#include "nova/image_io.hpp"
#include "nova/image_metrics.hpp"
#include "nova/runtime.hpp"
#include "nova/visualize.hpp"

namespace nova::cli {
namespace {

using Score = ViewScore;

std::string json_string(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    o += c;
  }
  return o + "\"";
}

void print_table(const std::string& title, const std::vector<Score>& scores) {
  std::cout << title << "\n  " << std::left << std::setw(28) << "view" << std::right << std::setw(9) << "PSNR"
            << std::setw(8) << "SSIM" << "\n";
  for (const Score& s : scores)
    std::cout << "  " << std::left << std::setw(28) << s.name << std::right << std::fixed << std::setprecision(2)
              << std::setw(9) << s.psnr << std::setprecision(4) << std::setw(8) << s.ssim << "\n";
}

void json_scores(std::ostream& o, const std::string& key, const std::vector<Score>& s) {
  o << "  " << json_string(key) << ": [";
  for (size_t i = 0; i < s.size(); ++i)
    o << (i ? ",\n    " : "\n    ") << "{\"name\": " << json_string(s[i].name) << ", \"psnr\": " << std::setprecision(6)
      << s[i].psnr << ", \"ssim\": " << s[i].ssim << "}";
  o << "\n  ]";
}

}  // namespace

// The command on one process, or as one rank of an MPI job (`mpi`): the views are dealt out
// round-robin, the scores gathered, and rank 0 scores the composition targets, prints and
// writes eval.json.
int eval_rank(const Args& args, MpiJob* mpi) {
  const bool lead = !mpi || mpi->rank() == 0;
  po::options_description desc("nova eval options");
  add_common_options(desc);
  desc.add_options()("run", po::value<std::string>()->required(), "trained run folder")(
      "scene", po::value<std::string>()->default_value(""), "scene folder (default: the run's)")(
      "views", po::value<std::string>()->default_value("auto"),
      "ground-truth views: cam0 (the paper's protocol: camera 0 at every time), heldout, all, or auto "
      "(cam0 when the scene has it, else heldout, else the --split frames)")(
      "split", po::value<std::string>()->default_value(""), "evaluate every frame of this split (Blender/D-NeRF: test)");
  add_blend_options(desc);
  po::variables_map vm;
  if (!parse(args, desc, vm, "usage: nova eval --run RUN [--scene DIR] [--views auto|cam0|heldout|all] [--split test]"))
    return 0;
  const auto t0 = std::chrono::steady_clock::now();
  const std::string run_dir = vm["run"].as<std::string>();
  const std::string split = vm["split"].as<std::string>();
  OpenRun run = open_run(run_dir, vm["scene"].as<std::string>(), true);
  Scene& scene = run.scene;
  std::vector<GroundTruthView> views;
  if (!split.empty()) {
    // A held-out split of the same scene (its own frames are the ground truth).
    Scene s = load_training_scene(run.files.scene, run.files.config, false, split);
    views = split_views(s, split);
  } else {
    std::string kind = vm["views"].as<std::string>();
    if (kind != "auto" && kind != "cam0" && kind != "heldout" && kind != "all")
      throw Error("--views '" + kind + "' is not one of auto, cam0, heldout, all");
    const auto has = [&](const std::string& k) {
      for (const auto& v : scene.gt_views)
        if (v.kind == k) return true;
      return false;
    };
    if (kind == "auto") kind = has("cam0") ? "cam0" : "heldout";
    for (auto& v : scene.gt_views)
      if (kind == "all" || v.kind == kind) views.push_back(std::move(v));
    if (views.empty() && scene.compose_gt.empty())
      throw Error("scene '" + scene.source + "' has no ground-truth views of kind '" + kind +
                  "' (train with --holdout N to hold frames out, or use --split)");
  }

  const DeviceInfo device = mpi ? rank_device(vm["device"].as<std::string>()) : select_device(vm["device"].as<std::string>());
  Runtime rt(device, false);
  ViewRenderer renderer(rt, run.files.config, run.geometry, run.files.checkpoint);
  RenderProgress progress;
  if (lead) renderer.set_progress([&](size_t done, size_t total) { progress(done, total); });
  // This rank's views: every size-th from its rank on.
  std::vector<size_t> mine;
  for (size_t i = 0; i < views.size(); ++i)
    if (!mpi || static_cast<int>(i % static_cast<size_t>(mpi->size())) == mpi->rank()) mine.push_back(i);
  std::vector<GroundTruthView> all_views;
  if (mpi) {
    all_views = std::move(views);
    for (size_t i : mine) views.push_back(all_views[i]);
  }
  progress.start("view 1/" + std::to_string(views.size()));
  const BlendChoice blend = blend_choice(vm);
  const std::string pictures = run_dir + "/eval";
  std::filesystem::create_directories(pictures);
  const auto write = [&](size_t, const std::string& stem, const Image8& out) {
    write_png(pictures + "/" + stem + ".png", out);
    progress.start(stem);
  };
  const auto write_and_count = [&](size_t i, const std::string& stem, const Image8& out) {
    write(i, stem, out);
    progress.start("view " + std::to_string(i + 2) + "/" + std::to_string(views.size()));
    if (lead) std::cerr << "\revaluated " << i + 1 << "/" << views.size() << std::flush;
  };
  std::vector<Score> scores = score_views(renderer, scene.num_objects, views, blend.scene_views, write_and_count);
  if (!views.empty() && lead) std::cerr << "\n";
  if (mpi) {  // every view's PSNR and SSIM, in the order of all views, on every rank
    std::vector<float> v(2 * all_views.size(), 0.0f);
    for (size_t k = 0; k < mine.size(); ++k) {
      v[2 * mine[k]] = static_cast<float>(scores[k].psnr);
      v[2 * mine[k] + 1] = static_cast<float>(scores[k].ssim);
    }
    mpi->reducer().sum(v);
    scores.clear();
    for (size_t i = 0; i < all_views.size(); ++i) scores.push_back({view_stem(all_views[i].name), v[2 * i], v[2 * i + 1]});
  }
  if (!lead) return 0;
  const std::vector<Score> compose = score_compose_targets(renderer, scene, blend.composition, write);

  const auto [mp, ms] = mean_scores(scores);
  const auto [cp, cs] = mean_scores(compose);
  if (!scores.empty()) print_table("views", scores);
  if (!compose.empty()) print_table("composition targets", compose);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::ostringstream json;
  json << "{\n  \"run\": " << json_string(run_dir) << ",\n  \"scene\": " << json_string(scene.source)
       << ",\n  \"step\": " << run.files.checkpoint.get("step")
       << ",\n  \"hard_blend_views\": " << (blend.scene_views ? "true" : "false")
       << ",\n  \"hard_blend_compose\": " << (blend.composition ? "true" : "false") << ",\n";
  json_scores(json, "views", scores);
  json << ",\n  \"mean_psnr\": " << std::setprecision(6) << mp << ",\n  \"mean_ssim\": " << ms << ",\n";
  json_scores(json, "compose", compose);
  json << ",\n  \"compose_mean_psnr\": " << cp << ",\n  \"compose_mean_ssim\": " << cs
       << ",\n  \"seconds\": " << secs << "\n}\n";
  const std::string path = run_dir + "/eval.json";
  {
    std::ofstream o(path + ".tmp");
    o << json.str();
    if (!o.flush()) throw Error("cannot write '" + path + "'");
  }
  std::filesystem::rename(path + ".tmp", path);
  std::cout << std::fixed << std::setprecision(2);
  if (!scores.empty()) std::cout << "mean PSNR " << mp << " dB, SSIM " << std::setprecision(4) << ms << " over " << scores.size() << " views\n";
  if (!compose.empty())
    std::cout << "composition targets: mean PSNR " << std::setprecision(2) << cp << " dB over " << compose.size() << "\n";
  std::cout << "wrote " << path << " and renders in " << pictures << "/ (" << std::setprecision(1) << secs << " s)\n";
  return 0;
}

int eval(const Args& args) { return run_as_ranks("eval", args, eval_rank); }

}  // namespace nova::cli

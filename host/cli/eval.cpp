// `nova eval --run RUN`: renders the scene's ground-truth views with the trained run and
// reports PSNR (OpenCV's number on 8-bit images) and SSIM per view, their means, and for
// synthetic scenes the composition targets; where a view's objects region is known, also the
// PSNR inside and outside it. Writes RUN/eval.json and the renders as PNGs.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli/mpi_job.hpp"
#include "cli/options.hpp"
#include "cli/render_progress.hpp"
#include "cli/run_setup.hpp"
#include "nova/eval/evaluation.hpp"
#include "nova/io/image_io.hpp"
#include "nova/metrics/image_metrics.hpp"
#include "nova/runtime/runtime.hpp"

namespace nova::cli {
namespace {

using Score = ViewScore;

bool has_regions(const std::vector<Score>& scores) {
  return std::any_of(scores.begin(), scores.end(), [](const Score& s) { return std::isfinite(s.object_psnr); });
}

// A region's PSNR right-aligned in `width`; "-" where the view has no objects region (a gt/
// view without an _objects.png) or no pixel in it.
std::string region_cell(double v, int width) {
  std::ostringstream o;
  if (std::isfinite(v)) o << std::fixed << std::setprecision(2) << v;
  else o << "-";
  const std::string text = o.str();
  return std::string(static_cast<size_t>(std::max(0, width - static_cast<int>(text.size()))), ' ') + text;
}

// With the views' masks known, three more columns: PSNR inside the objects and outside them,
// and how opaque the objects render inside them.
void print_table(const std::string& title, const std::vector<Score>& scores) {
  const bool regions = has_regions(scores);
  std::cout << title << "\n  " << std::left << std::setw(28) << "view" << std::right << std::setw(9) << "PSNR"
            << std::setw(8) << "SSIM";
  if (regions) std::cout << std::setw(9) << "objects" << std::setw(12) << "background" << std::setw(9) << "opacity";
  std::cout << "\n";
  for (const Score& s : scores) {
    std::cout << "  " << std::left << std::setw(28) << s.name << std::right << std::fixed << std::setprecision(2)
              << std::setw(9) << s.psnr << std::setprecision(4) << std::setw(8) << s.ssim;
    if (regions) std::cout << region_cell(s.object_psnr, 9) << region_cell(s.background_psnr, 12) << region_cell(s.object_opacity, 9);
    std::cout << "\n";
  }
}

// A score as eval.json keeps it: 6 significant digits, which the JSON writer prints as the
// shortest text that reads back the same. Non-finite values are written as null.
double score_value(double v) {
  if (!std::isfinite(v)) return v;
  std::ostringstream s;
  s << std::setprecision(6) << v;
  return std::stod(s.str());
}

nlohmann::ordered_json json_scores(const std::vector<Score>& scores) {
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (const Score& s : scores) {
    nlohmann::ordered_json v = {{"name", s.name}, {"psnr", score_value(s.psnr)}, {"ssim", score_value(s.ssim)}};
    if (std::isfinite(s.object_psnr) || std::isfinite(s.background_psnr)) {
      v["object_psnr"] = score_value(s.object_psnr);
      v["background_psnr"] = score_value(s.background_psnr);
      v["object_opacity"] = score_value(s.object_opacity);
    }
    list.push_back(v);
  }
  return list;
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
      "(cam0 when the scene has it, else heldout; not with --split)")(
      "split", po::value<std::string>()->default_value(""), "evaluate every frame of this split (Blender/D-NeRF: test)");
  add_blend_options(desc);
  po::variables_map vm;
  if (!parse(args, desc, vm, "usage: nova eval --run RUN [--scene DIR] [--views auto|cam0|heldout|all] [--split test]"))
    return 0;
  const auto t0 = std::chrono::steady_clock::now();
  const std::string run_dir = vm["run"].as<std::string>();
  const std::string split = vm["split"].as<std::string>();
  if (!split.empty() && !vm["views"].defaulted())
    throw Error("--views and --split both choose the views: pass one (--split scores that split's frames)");
  OpenRun run = open_run(run_dir, vm["scene"].as<std::string>(), true);
  Scene& scene = run.scene;
  std::vector<GroundTruthView> views;
  if (!split.empty()) {
    // A held-out split of the same scene (its own frames are the ground truth).
    const std::string& scene_dir = vm["scene"].as<std::string>();
    Scene s = load_training_scene(scene_dir.empty() ? run.files.scene : scene_dir, run.files.config, false, split);
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
    if (lead) count_progress("evaluated", i + 1, views.size());
  };
  std::vector<Score> scores = score_views(renderer, scene.num_objects, views, blend.scene_views, write_and_count);
  if (mpi) {  // every view's scores, in the order of all views, on every rank (NaN travels as is)
    constexpr size_t kFields = 5;
    std::vector<float> v(kFields * all_views.size(), 0.0f);
    for (size_t k = 0; k < mine.size(); ++k) {
      const Score& s = scores[k];
      float* row = &v[kFields * mine[k]];
      row[0] = static_cast<float>(s.psnr);
      row[1] = static_cast<float>(s.ssim);
      row[2] = static_cast<float>(s.object_psnr);
      row[3] = static_cast<float>(s.background_psnr);
      row[4] = static_cast<float>(s.object_opacity);
    }
    mpi->reducer().sum(v);
    scores.clear();
    for (size_t i = 0; i < all_views.size(); ++i) {
      const float* row = &v[kFields * i];
      scores.push_back({view_stem(all_views[i].name), row[0], row[1], row[2], row[3], row[4]});
    }
  }
  if (!lead) return 0;
  // A checkpoint from static pretraining has no objects to place: its targets are left out.
  if (!renderer.has_objects() && !scene.compose_gt.empty())
    std::cerr << "note: composition targets left out: the run's checkpoint is from static pretraining "
                 "(no object NeRF trained yet)\n";
  const std::vector<Score> compose = renderer.has_objects()
                                         ? score_compose_targets(renderer, scene, blend.composition, write)
                                         : std::vector<Score>{};

  const auto [mp, ms] = mean_scores(scores);
  const auto [cp, cs] = mean_scores(compose);
  if (!scores.empty()) print_table("views", scores);
  if (!compose.empty()) print_table("composition targets", compose);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  nlohmann::ordered_json json;
  json["run"] = run_dir;
  json["scene"] = scene.source;
  json["step"] = std::stol(run.files.checkpoint.get("step"));
  json["hard_blend_views"] = blend.scene_views;
  json["hard_blend_compose"] = blend.composition;
  json["views"] = json_scores(scores);
  json["mean_psnr"] = score_value(mp);
  json["mean_ssim"] = score_value(ms);
  const auto [mop, mbp] = mean_region_scores(scores);
  const bool regions = std::isfinite(mop);  // some view has an objects region
  const double opacity = mean_object_opacity(scores);
  if (regions) {
    json["mean_object_psnr"] = score_value(mop);
    json["mean_background_psnr"] = score_value(mbp);
    json["mean_object_opacity"] = score_value(opacity);
  }
  json["compose"] = json_scores(compose);
  const auto [cop, cbp] = mean_region_scores(compose);
  const double compose_opacity = mean_object_opacity(compose);
  if (std::isfinite(cop)) {
    json["compose_mean_object_psnr"] = score_value(cop);
    json["compose_mean_background_psnr"] = score_value(cbp);
    json["compose_mean_object_opacity"] = score_value(compose_opacity);
  }
  json["compose_mean_psnr"] = score_value(cp);
  json["compose_mean_ssim"] = score_value(cs);
  json["seconds"] = score_value(secs);
  const std::string path = run_dir + "/eval.json";
  {
    std::ofstream o(path + ".tmp");
    o << json.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) << "\n";
    if (!o.flush()) throw Error("cannot write '" + path + "'");
  }
  std::filesystem::rename(path + ".tmp", path);
  std::cout << std::fixed << std::setprecision(2);
  // The objects first: they are a few percent of a frame, and the whole frame's mean hides them.
  if (regions) {
    std::cout << "inside the objects' masks " << std::setprecision(2) << mop << " dB, outside " << mbp << " dB";
    if (std::isfinite(opacity)) std::cout << "; the objects render " << opacity << " opaque there";
    std::cout << "\n";
  }
  if (!scores.empty()) std::cout << "mean PSNR " << mp << " dB, SSIM " << std::setprecision(4) << ms << " over " << scores.size() << " views\n";
  if (!compose.empty()) {
    std::cout << "composition targets: ";
    if (std::isfinite(cop)) {
      std::cout << "inside the instances " << std::setprecision(2) << cop << " dB";
      if (std::isfinite(compose_opacity)) std::cout << " (" << compose_opacity << " opaque)";
      std::cout << ", ";
    }
    std::cout << "mean PSNR " << std::setprecision(2) << cp << " dB over " << compose.size() << "\n";
  }
  std::cout << "wrote " << path << " and renders in " << pictures << "/ (" << std::setprecision(1) << secs << " s)\n";
  return 0;
}

int eval(const Args& args) { return run_as_ranks("eval", args, eval_rank); }

}  // namespace nova::cli

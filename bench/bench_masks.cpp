// `nova-bench masks`: nova masks (include/nova/masks/motion_masks.hpp) against known masks: the
// synthetic family's exact object masks (seeds) and a scene's own masks folder (--truth).
// Per scene the IoU of the objects' union per frame (mean and worst frame), the object count
// and the seconds; the settings are the MotionMaskOptions fields, so that dev seeds can choose them.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "bench.hpp"
#include "options.hpp"
#include "data/fs_util.hpp"
#include "nova/runtime/error.hpp"
#include "nova/io/image_io.hpp"
#include "nova/masks/motion_masks.hpp"
#include "nova/data/scene_io.hpp"
#include "nova/data/synth.hpp"

namespace nova::bench {
namespace {

namespace fs = std::filesystem;

// A masks folder's objects per frame, [object][frame]: numbered folders 1..K, or the PNGs in
// it as one object.
std::vector<std::vector<Image8>> truth_objects(const fs::path& dir, int width, int height) {
  const auto sub = data::numbered_subdirs(dir);
  std::vector<fs::path> folders;
  for (const auto& [k, p] : sub)
    if (k > 0) folders.push_back(p);
  if (sub.empty()) folders.push_back(dir);
  std::vector<std::vector<Image8>> out;
  for (const auto& folder : folders) {
    const auto files = data::list_files(folder, {".png"});
    if (!out.empty() && files.size() != out[0].size())
      throw Error(folder.string() + ": another number of masks than folder 1");
    out.emplace_back();
    for (const auto& f : files) out.back().push_back(resize_nearest(read_mask(f.string()), width, height));
  }
  return out;
}

// Per frame the union of [object][frame] masks.
std::vector<Image8> union_per_frame(const std::vector<std::vector<Image8>>& objects) {
  std::vector<Image8> out;
  for (size_t i = 0; i < (objects.empty() ? 0 : objects[0].size()); ++i) {
    const Image8& first = objects[0][i];
    std::vector<Image8> frame(1, Image8(first.width, first.height, 1));  // entry 0, the background, is skipped
    for (const auto& k : objects) frame.push_back(k[i]);
    out.push_back(objects_union(frame));
  }
  return out;
}

// Objects told apart: each true object takes the made object it shares the most pixels with
// over the video, and scores the mean IoU against it over the frames where either shows.
// Two objects merged into one made mask, or one split between two, score low here though
// their union scores well.
double object_iou(const std::vector<std::vector<Image8>>& made, const std::vector<std::vector<Image8>>& truth) {
  double sum = 0;
  int pairs = 0;
  for (const auto& t : truth) {
    size_t best = 0, best_shared = 0;
    for (size_t k = 1; k < made.size(); ++k) {
      size_t shared = 0;
      for (size_t i = 0; i < t.size(); ++i)
        for (size_t p = 0; p < t[i].data.size(); ++p) shared += t[i].data[p] && made[k][i].data[p];
      if (shared > best_shared || best == 0) best = k, best_shared = std::max(shared, best_shared);
    }
    for (size_t i = 0; i < t.size(); ++i) {
      bool any = false;
      for (size_t p = 0; p < t[i].data.size() && !any; ++p) any = t[i].data[p] || (best && made[best][i].data[p]);
      if (!any) continue;
      sum += best ? mask_iou(made[best][i], t[i]) : 0.0;
      ++pairs;
    }
  }
  return pairs ? sum / pairs : 1.0;
}

struct Score {
  std::string name;
  int frames = 0, objects = 0, true_objects = 0;
  double mean = 0, worst = 1, objects_iou = 0, seconds = 0;
};

Score score(const std::string& name, const Scene& scene, const std::vector<std::vector<Image8>>& objects,
            const MotionMaskOptions& opt, const std::string& out) {
  const std::vector<Image8> truth = union_per_frame(objects);
  const auto t0 = std::chrono::steady_clock::now();
  const MotionMasks m = make_motion_masks(scene, opt);
  if (!out.empty()) write_motion_masks(scene, m, out + "/" + scene.name, true);
  Score s;
  s.name = name;
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  s.frames = int(scene.frames.size());
  s.objects = m.nothing_moves ? 0 : m.objects();
  s.true_objects = int(objects.size());
  s.objects_iou = object_iou(m.masks, objects);
  if (truth.size() != scene.frames.size()) throw Error(name + ": " + std::to_string(truth.size()) + " true masks for " +
                                                       std::to_string(scene.frames.size()) + " frames");
  std::string per, errors;
  for (size_t i = 0; i < truth.size(); ++i) {
    std::vector<Image8> frame_masks;
    for (const auto& k : m.masks) frame_masks.push_back(k[i]);
    const Image8 made = objects_union(frame_masks);
    const double iou = mask_iou(made, truth[i]);
    // Which error it is: true pixels missed and false pixels taken, each as a fraction of the truth.
    size_t missed = 0, extra = 0, real = 0;
    for (size_t p = 0; p < made.data.size(); ++p) {
      real += truth[i].data[p] != 0;
      missed += truth[i].data[p] && !made.data[p];
      extra += !truth[i].data[p] && made.data[p];
    }
    char e[32];
    std::snprintf(e, sizeof e, " %.2f/%.2f", double(missed) / double(std::max<size_t>(real, 1)),
                  double(extra) / double(std::max<size_t>(real, 1)));
    errors += e;
    s.mean += iou / double(truth.size());
    s.worst = std::min(s.worst, iou);
    char b[16];
    std::snprintf(b, sizeof b, " %.2f", iou);
    per += b;
  }
  std::cout << name << ": per frame" << per << "\n" << name << ": missed/extra" << errors << "\n";
  return s;
}

}  // namespace

int masks(const Args& args) {
  MotionMaskOptions opt;
  auto text = [](double v) {
    std::ostringstream s;
    s << v;
    return s.str();
  };
  const Options o(args, {{"seeds", ""},
                         {"scene", ""},
                         {"truth", ""},
                         {"factor", "0"},
                         {"offsets", "1,2,3,4"},
                         {"match-radius", std::to_string(opt.match_radius)},
                         {"colour-scale", text(opt.colour_scale)},
                         {"depth-scale", text(opt.depth_scale)},
                         {"occlusion-margin", text(opt.occlusion_margin)},
                         {"threshold-floor", text(opt.threshold_floor)},
                         {"threshold-mads", text(opt.threshold_mads)},
                         {"min-area", text(opt.min_area)},
                         {"peel-radius", text(opt.peel_radius)},
                         {"depth-search", text(opt.depth_search)},
                         {"grow-depth", text(opt.grow_depth)},
                         {"grow-limit", text(opt.grow_limit)},
                         {"min-track-frames", text(opt.min_track_frames)},
                         {"global-fit", "off"},
                         {"out", ""},
                         {"grabcut-band", text(opt.grabcut_band)},
                         {"no-grabcut", "off"}});
  if (o.help()) {
    std::cout << o.usage("masks") << "\n--seeds: family seeds; --scene DIR [--truth DIR] [--factor F]: a NOVA "
                 "scene and its true masks folder (default SCENE/motion_masks); the rest: MotionMaskOptions\n";
    return 0;
  }
  opt.offsets.clear();
  for (long v : o.integers("offsets")) opt.offsets.push_back(int(v));
  opt.colour_scale = std::stod(o.str("colour-scale"));
  opt.match_radius = int(o.integer("match-radius"));
  opt.depth_scale = std::stod(o.str("depth-scale"));
  opt.occlusion_margin = std::stod(o.str("occlusion-margin"));
  opt.threshold_floor = std::stod(o.str("threshold-floor"));
  opt.threshold_mads = std::stod(o.str("threshold-mads"));
  opt.min_area = std::stod(o.str("min-area"));
  opt.peel_radius = std::stod(o.str("peel-radius"));
  opt.depth_search = std::stod(o.str("depth-search"));
  opt.grow_depth = std::stod(o.str("grow-depth"));
  opt.grow_limit = std::stod(o.str("grow-limit"));
  opt.min_track_frames = std::stod(o.str("min-track-frames"));
  opt.per_frame_fit = !o.flag("global-fit");
  opt.grabcut = !o.flag("no-grabcut");
  opt.grabcut_band = std::stod(o.str("grabcut-band"));
  std::vector<Score> scores;
  ScratchDir scratch("masks");
  for (long seed : o.integers("seeds")) {
    const fs::path dir = scratch / ("family" + std::to_string(seed));
    write_synthetic_scene(dir.string(), "family", uint32_t(seed));
    LoadOptions load;
    load.static_only = true;
    load.load_gt = false;
    const Scene scene = load_scene(dir.string(), load);
    const SynthWorld world("family", uint32_t(seed));
    const int n = int(scene.frames.size());
    std::vector<std::vector<Image8>> truth(size_t(world.objects()));
    for (int i = 0; i < n; ++i) {
      const auto masks = world.render(world.camera(i), frame_time(i, n)).masks;
      for (size_t k = 0; k < truth.size(); ++k) truth[k].push_back(masks[k + 1]);
    }
    scores.push_back(score("family seed " + std::to_string(seed), scene, truth, opt, o.str("out")));
  }
  if (!o.str("scene").empty()) {
    const std::string dir = o.str("scene");
    LoadOptions load;
    load.format = "nova";
    load.static_only = true;
    load.load_gt = false;
    load.factor = int(o.integer("factor"));
    const Scene scene = load_scene(dir, load);
    std::string truth_dir = o.str("truth");
    if (truth_dir.empty()) truth_dir = (fs::path(dir) / "motion_masks").string();
    const auto& f = scene.frames[0].rgb;
    scores.push_back(score(scene.name, scene, truth_objects(truth_dir, f.width, f.height), opt, o.str("out")));
  }
  std::printf("\n%-18s %6s %8s %8s %8s %8s %8s\n", "scene", "frames", "objects", "IoU", "worst", "objects", "seconds");
  double sum = 0, sum_objects = 0;
  for (const Score& s : scores) {
    std::printf("%-18s %6d %4d/%-3d %8.3f %8.3f %8.3f %8.1f\n", s.name.c_str(), s.frames, s.objects, s.true_objects,
                s.mean, s.worst, s.objects_iou, s.seconds);
    sum += s.mean;
    sum_objects += s.objects_iou;
  }
  if (scores.size() > 1)
    std::printf("%-18s %6s %8s %8.3f %8s %8.3f\n", "mean", "", "", sum / double(scores.size()), "",
                sum_objects / double(scores.size()));
  std::printf("IoU: the objects' union per frame (mean, worst frame); objects: each true object against the made "
              "object it shares most with, mean over the frames where either shows\n");
  return 0;
}

}  // namespace nova::bench

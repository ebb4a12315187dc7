#include "nova/eval/evaluation.hpp"

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <optional>

#include "nova/metrics/image_metrics.hpp"
#include "nova/data/scene_io.hpp"
#include "nova/io/pictures.hpp"

namespace nova {

Scene load_training_scene(const std::string& dir, const TrainConfig& config, bool load_gt, const std::string& split) {
  LoadOptions o;
  o.factor = config.factor;
  o.static_only = config.static_only;
  o.load_gt = load_gt;
  o.split = split;
  Scene s = load_scene(dir, o);
  if (config.holdout > 0 && split == "train") hold_out_frames(s, config.holdout);
  return s;
}

std::vector<FolderFrame> folder_frames(const Scene& scene) {
  // The held-out frames at their folder indices, the training frames in order in the others.
  // Ground-truth cameras that were never folder frames (folder_index -1) take no index.
  size_t held = 0;
  for (const GroundTruthView& v : scene.gt_views) held += v.folder_index >= 0;
  std::vector<std::optional<FolderFrame>> slots(scene.frames.size() + held);
  for (const GroundTruthView& v : scene.gt_views) {
    if (v.folder_index < 0) continue;
    const size_t i = static_cast<size_t>(v.folder_index);
    if (i >= slots.size() || slots[i])
      throw Error("scene '" + scene.name + "': held-out view " + v.name + " claims folder frame " +
                      std::to_string(i) + " of " + std::to_string(slots.size()),
                  kExitInternal);
    slots[i] = FolderFrame{v.camera, v.time};
  }
  size_t next = 0;
  for (const Frame& f : scene.frames) {
    while (slots[next]) ++next;
    slots[next++] = FolderFrame{f.camera, f.time};
  }
  std::vector<FolderFrame> out;
  for (const auto& s : slots) out.push_back(*s);
  return out;
}

std::vector<GroundTruthView> split_views(Scene& split_scene, const std::string& split) {
  std::vector<GroundTruthView> views;
  for (size_t i = 0; i < split_scene.frames.size(); ++i) {
    Frame& f = split_scene.frames[i];
    char name[32];
    std::snprintf(name, sizeof name, "%s_%03zu", split.c_str(), i);
    GroundTruthView v;
    v.name = name;
    v.kind = split;
    v.time_index = static_cast<int>(i);
    v.time = f.time;
    v.camera = f.camera;
    v.rgb = std::move(f.rgb);
    views.push_back(std::move(v));
  }
  return views;
}

std::string view_stem(const std::string& name) {
  std::string stem = name;
  for (char& c : stem)
    if (c == '/') c = '_';
  if (stem.size() > 4 && stem.substr(stem.size() - 4) == ".png") stem.resize(stem.size() - 4);
  return stem;
}

namespace {

// The objects' rendered masks summed, averaged over the region's pixels (>= 128, as
// region_psnr reads it); the background's mask is the first when it is drawn.
double region_opacity(const ViewImage& img, const Image8& region, bool background) {
  const size_t first = background ? 1 : 0;
  if (img.masks.size() <= first) return std::nan("");
  double sum = 0;
  size_t n = 0;
  for (size_t p = 0; p < region.data.size(); ++p) {
    if (region.data[p] < 128) continue;
    double a = 0;
    for (size_t k = first; k < img.masks.size(); ++k) a += img.masks[k].at(p);
    sum += a;
    ++n;
  }
  return n ? sum / static_cast<double>(n) : std::nan("");
}

}  // namespace

std::vector<ViewScore> score_views(ViewRenderer& renderer, int num_objects, const std::vector<GroundTruthView>& views,
                                   bool hard_blend, const RenderSink& sink) {
  std::vector<ViewScore> scores;
  for (size_t i = 0; i < views.size(); ++i) {
    const GroundTruthView& v = views[i];
    ViewRequest req;
    req.camera = v.camera;
    req.hard_blend = hard_blend;
    req.instances = scene_instances(num_objects, v.time);
    const ViewImage img = renderer.render(req);
    const Image8 out = float_rgb_to_image(img.rgb, img.width, img.height);
    const std::string stem = view_stem(v.name);
    if (sink) sink(i, stem, out);
    ViewScore score{stem, psnr(out, v.rgb), ssim(out, v.rgb)};
    if (!v.objects.empty()) {
      score.object_psnr = region_psnr(out, v.rgb, v.objects, true);
      score.background_psnr = region_psnr(out, v.rgb, v.objects, false);
      score.object_opacity = region_opacity(img, v.objects, true);
    }
    scores.push_back(score);
  }
  return scores;
}

std::vector<ViewScore> score_compose_targets(ViewRenderer& renderer, const Scene& scene, bool hard_blend,
                                             const RenderSink& sink) {
  std::vector<ViewScore> scores;
  const std::vector<FolderFrame> frames = folder_frames(scene);
  for (size_t i = 0; i < scene.compose.targets.size(); ++i) {
    const ComposeTarget& t = scene.compose.targets[i];
    const Image8* gt = nullptr;
    const Image8* objects = nullptr;
    for (const auto& c : scene.compose_gt)
      if (c.name == t.name) {
        gt = &c.rgb;
        objects = c.objects.empty() ? nullptr : &c.objects;
      }
    if (!gt || t.camera < 0 || t.camera >= static_cast<int>(frames.size())) continue;
    // Objects alone where none is in view: a black truth that a black render matches exactly
    // (PSNR "infinite", 361 in OpenCV's number), which would swamp every mean it entered.
    if (!t.background && std::all_of(gt->data.begin(), gt->data.end(), [](uint8_t v) { return v == 0; })) {
      std::cerr << "note: composition target " << t.name << " shows nothing (no object in view): not scored\n";
      continue;
    }
    ViewRequest req;
    req.camera = frames[static_cast<size_t>(t.camera)].camera;
    req.background = t.background;
    req.hard_blend = hard_blend;
    for (const ComposeInstance& inst : t.instances) {
      const InstancePivot pv = renderer.pivot_for(inst);
      if (pv.from == InstancePivot::From::Origin)
        std::cerr << "warning: composition target " << t.name << ": object " << inst.object
                  << " has no density at t=" << inst.time << "; it turns about the scene origin\n";
      req.instances.push_back(placed_instance(inst, pv.pivot));
    }
    const ViewImage img = renderer.render(req);
    const Image8 out = float_rgb_to_image(img.rgb, img.width, img.height);
    if (sink) sink(i, "compose_" + t.name, out);
    ViewScore score{t.name, psnr(out, *gt), ssim(out, *gt)};
    if (objects) {
      score.object_psnr = region_psnr(out, *gt, *objects, true);
      score.background_psnr = region_psnr(out, *gt, *objects, false);
      score.object_opacity = region_opacity(img, *objects, t.background);
    }
    scores.push_back(score);
  }
  return scores;
}

std::pair<double, double> mean_scores(const std::vector<ViewScore>& s) {
  double p = 0, q = 0;
  for (const ViewScore& x : s) {
    p += x.psnr;
    q += x.ssim;
  }
  return {s.empty() ? 0 : p / s.size(), s.empty() ? 0 : q / s.size()};
}

namespace {

// The mean of one score over the views where it is finite (NaN where none is).
double finite_mean_of(const std::vector<ViewScore>& s, double ViewScore::*field) {
  double sum = 0;
  int n = 0;
  for (const ViewScore& x : s)
    if (std::isfinite(x.*field)) {
      sum += x.*field;
      ++n;
    }
  return n ? sum / n : std::nan("");
}

}  // namespace

std::pair<double, double> mean_region_scores(const std::vector<ViewScore>& s) {
  return {finite_mean_of(s, &ViewScore::object_psnr), finite_mean_of(s, &ViewScore::background_psnr)};
}

double mean_object_opacity(const std::vector<ViewScore>& s) { return finite_mean_of(s, &ViewScore::object_opacity); }

}  // namespace nova

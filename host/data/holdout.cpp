// The hold-out split and the objects region of a ground-truth view: plain data work on a
// Scene, beside the readers that fill one.
#include "nova/data/scene_io.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <utility>
#include <vector>

#include "nova/runtime/error.hpp"

namespace nova {

Image8 objects_region(const std::vector<Image8>& masks) {
  if (masks.size() < 2) return {};
  Image8 out = masks[1];
  for (size_t k = 2; k < masks.size(); ++k)
    for (size_t p = 0; p < out.data.size(); ++p) out.data[p] = std::max(out.data[p], masks[k].data[p]);
  return out;
}

std::string ground_truth_objects_name(const std::string& image) {
  return std::filesystem::path(image).replace_extension().string() + "_objects.png";
}

void hold_out_frames(Scene& scene, int every) {
  if (every <= 0) return;
  if (scene.frames.size() < 2)
    throw Error("option 'holdout': scene '" + scene.name + "' has too few frames to hold any out");
  // Frames 0, N, 2N, ... are held out: N = 1 takes them all, and training needs two.
  const size_t n = scene.frames.size(), held = (n + static_cast<size_t>(every) - 1) / static_cast<size_t>(every);
  if (n - held < 2)
    throw Error("option 'holdout' " + std::to_string(every) + ": holding out frames 0, " + std::to_string(every) +
                ", " + std::to_string(2 * every) + ", ... of scene '" + scene.name + "' leaves " +
                std::to_string(n - held) + " of its " + std::to_string(n) + " frames to train on (at least 2 are needed)");
  std::vector<Frame> kept;
  for (size_t i = 0; i < scene.frames.size(); ++i) {
    Frame& f = scene.frames[i];
    if (i % static_cast<size_t>(every) != 0) {
      kept.push_back(std::move(f));
      continue;
    }
    GroundTruthView v;
    char name[32];
    std::snprintf(name, sizeof name, "frame_%03zu", i);
    v.name = name;
    v.kind = "heldout";
    v.time_index = static_cast<int>(i);
    v.folder_index = static_cast<int>(i);
    v.time = f.time;
    v.camera = f.camera;
    v.rgb = std::move(f.rgb);
    v.objects = objects_region(f.masks);
    scene.gt_views.push_back(std::move(v));
  }
  scene.frames = std::move(kept);
  scene.notes.push_back("held out every " + std::to_string(every) + "th frame (" +
                        std::to_string(scene.gt_views.size()) + " views) for evaluation");
}

}  // namespace nova

#pragma once
// Loading the scene a run trains or is evaluated on, the same way for train, render and eval.
#include <string>

#include "nova/scene.hpp"
#include "nova/train_config.hpp"
#include "nova/view_renderer.hpp"

namespace nova::cli {

// load_scene with the run's image factor, then the run's hold-out split (every n-th frame
// leaves training and becomes a "heldout" ground-truth view). Error (exit 2) when the folder
// is missing or bad.
Scene load_training_scene(const std::string& dir, const TrainConfig& config, bool load_gt = false,
                          const std::string& split = "train");

// A trained run and its scene (the run's own unless `scene_dir` is given).
struct OpenRun {
  RunFiles files;
  Scene scene;
  RayGeometry geometry;
};
OpenRun open_run(const std::string& run_dir, const std::string& scene_dir, bool load_gt,
                 const std::string& split = "train");

// Writes into `dir` through a staging folder renamed at the end, so that a failure leaves
// no partial output. `dir` must not exist unless `replace`.
class StagedFolder {
 public:
  StagedFolder(std::string dir, bool replace);
  ~StagedFolder();  // removes the staging folder unless committed
  const std::string& path() const { return staging_; }
  void commit();

 private:
  std::string dir_, staging_;
  bool committed_ = false;
};

}  // namespace nova::cli

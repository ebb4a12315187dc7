#pragma once
// Loading the scene a run trains or is evaluated on, the same way for train, render and eval.
#include <string>

#include "nova/eval/evaluation.hpp"
#include "nova/train/run_folder.hpp"
#include "nova/model/scene.hpp"
#include "nova/train/train_config.hpp"
#include "nova/model/view_renderer.hpp"

namespace nova::cli {

// load_training_scene (the run's factor and hold-out split) is nova::load_training_scene in
// nova/eval/evaluation.hpp, shared with nova-bench.

// A trained run and its scene (the run's own unless `scene_dir` is given).
struct OpenRun {
  RunFiles files;
  Scene scene;
  RayGeometry geometry;
};
OpenRun open_run(const std::string& run_dir, const std::string& scene_dir, bool load_gt,
                 const std::string& split = "train");

// The scene a run's config.ini (at `config_path`) names: Error, pointing to --scene, when it
// names none or the path no longer exists (moved, or relative to another folder).
std::string named_scene(const std::string& scene, const std::string& config_path);

// Error naming `option` unless `path` can be created: its nearest existing ancestor must be a
// writable folder. Checked before any work, so that a bad --out costs nothing.
void check_output_location(const std::string& path, const std::string& option);

// Writes into `dir` through a staging folder renamed at the end, so that a failure leaves
// no partial output. `dir` must not exist unless `replace`.
class StagedFolder {
 public:
  StagedFolder(std::string dir, bool replace);
  ~StagedFolder();  // removes the staging folder unless committed
  const std::string& path() const { return staging_; }
  // Where the staging folder of `dir` is (other ranks of an MPI job write into it).
  static std::string staging_path(std::string dir);
  void commit();

 private:
  std::string dir_, staging_;
  bool committed_ = false;
};

}  // namespace nova::cli

#pragma once
// A run folder: the files `nova train` writes into it and that resume, render and eval read
// back, named here once, and the one check that a checkpoint holds the networks a
// configuration describes, so that resume and render refuse the same mismatches.
#include <string>
#include <utility>

#include "nova/model/checkpoint.hpp"
#include "nova/model/model_config.hpp"
#include "nova/train/train_config.hpp"

namespace nova {

inline const std::string kCheckpointFile = "checkpoint.bin";
inline const std::string kConfigFile = "config.ini";
inline const std::string kMetricsFile = "metrics.jsonl";

// The text of a run's config.ini: every option of `config`, then the scene it trains on by
// its absolute path (so that render and eval find it from any folder).
std::string run_config_text(const TrainConfig& config, const std::string& scene_source);

// What a run folder holds for inference.
struct RunFiles {
  std::string dir;
  TrainConfig config;
  std::string scene;  // the scene folder it trained on
  Checkpoint checkpoint;
};

class RunFolder {
 public:
  explicit RunFolder(std::string dir) : dir_(std::move(dir)) {}
  const std::string& dir() const { return dir_; }
  std::string config_path() const { return dir_ + "/" + kConfigFile; }
  std::string checkpoint_path() const { return dir_ + "/" + kCheckpointFile; }
  std::string metrics_path() const { return dir_ + "/" + kMetricsFile; }

  // Reads config.ini (a run file: options it lacks mean what they meant when it was written)
  // and checkpoint.bin, and checks that the checkpoint holds the networks config.ini
  // describes; Error (exit 2) naming what is missing or bad.
  RunFiles read() const;
  // The scene config.ini names (empty when none), without reading the checkpoint.
  std::string scene() const;
  // Error (exit 2) naming the checkpoint file, `configured_by` (what the configuration came
  // from) and both networks unless `ck` holds the networks `config` describes.
  void check_networks(const Checkpoint& ck, const ModelConfig& config, const std::string& configured_by) const;

 private:
  // config.ini as a run file, and the scene it names.
  TrainConfig read_config(std::string& scene) const;
  std::string dir_;
};

}  // namespace nova

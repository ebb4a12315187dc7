#include "nova/train/run_folder.hpp"

#include <filesystem>
#include <utility>
#include <vector>

#include "nova/runtime/error.hpp"
#include "runtime/read_file.hpp"

namespace nova {

std::string run_config_text(const TrainConfig& config, const std::string& scene_source) {
  std::error_code ec;
  // weakly_canonical, not lexically_normal: "link/../s" must name the folder the OS read.
  const std::filesystem::path scene = std::filesystem::weakly_canonical(std::filesystem::absolute(scene_source), ec);
  return format_config(config, {"# the scene this run trained on", "scene = " + (ec ? scene_source : scene.string())});
}

TrainConfig RunFolder::read_config(std::string& scene) const {
  if (!std::filesystem::is_directory(dir_)) throw Error("run folder '" + dir_ + "' does not exist");
  const std::string cfg = config_path();
  const std::optional<std::string> text = read_file(cfg);
  if (!text) throw Error("run folder '" + dir_ + "' has no " + kConfigFile + " (not a nova run?)");
  std::vector<std::pair<std::string, std::string>> others;
  TrainConfig config = parse_config_text(*text, cfg, &others, ConfigFile::RunFile);
  for (auto& [k, v] : others)
    if (k == "scene") scene = v;
  return config;
}

std::string RunFolder::scene() const {
  std::string scene;
  read_config(scene);
  return scene;
}

RunFiles RunFolder::read() const {
  namespace fs = std::filesystem;
  const std::string cfg = config_path();
  RunFiles r;
  r.dir = dir_;
  r.config = read_config(r.scene);
  if (!fs::exists(checkpoint_path()))
    throw Error("run folder '" + dir_ + "' has no " + kCheckpointFile + " yet (training has not saved one)");
  r.checkpoint = read_checkpoint(checkpoint_path());
  check_networks(r.checkpoint, r.config, "'" + cfg + "'");
  return r;
}

void RunFolder::check_networks(const Checkpoint& ck, const ModelConfig& config,
                               const std::string& configured_by) const {
  const std::string written = ck.get("networks"), configured = network_fingerprint(config);
  if (written != configured)
    throw Error("checkpoint '" + checkpoint_path() + "' does not fit " + configured_by + ": written for networks '" +
                written + "', configured '" + configured + "'");
}

}  // namespace nova

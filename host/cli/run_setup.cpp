#include "cli/run_setup.hpp"

#include <filesystem>
#include <unistd.h>

#include "nova/runtime/error.hpp"

namespace nova::cli {
namespace fs = std::filesystem;

OpenRun open_run(const std::string& run_dir, const std::string& scene_dir, bool load_gt,
                 const std::string& split) {
  OpenRun r{RunFolder(run_dir).read(), {}, {}};
  const std::string dir = scene_dir.empty() ? named_scene(r.files.scene, RunFolder(run_dir).config_path()) : scene_dir;
  r.scene = load_training_scene(dir, r.files.config, load_gt, split);
  r.geometry = ray_geometry(r.scene);
  return r;
}

std::string named_scene(const std::string& scene, const std::string& config_path) {
  if (scene.empty()) throw Error("'" + config_path + "' names no scene: pass --scene");
  if (!fs::exists(scene))
    throw Error("the scene '" + scene + "' named in '" + config_path +
                "' does not exist (moved, or a relative path from another folder): pass --scene");
  return scene;
}

void check_output_location(const std::string& path, const std::string& option) {
  if (path.empty()) throw Error(option + ": empty path");
  std::error_code ec;
  const fs::path full = fs::absolute(path, ec).lexically_normal();
  if (ec) throw Error(option + " '" + path + "': " + ec.message());
  // The nearest part of the path that exists (a file in the way reads as absent below it).
  fs::path p = full;
  while (!fs::exists(p, ec) && p.has_parent_path() && p.parent_path() != p) p = p.parent_path();
  if (!fs::is_directory(p, ec))
    throw Error(p == full ? option + " '" + path + "' is a file, not a folder"
                          : option + " '" + path + "': '" + p.string() + "' is not a folder");
  if (::access(p.c_str(), W_OK) != 0) throw Error(option + " '" + path + "': '" + p.string() + "' is not writable");
}

std::string StagedFolder::staging_path(std::string dir) {
  while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
  return dir + ".partial";
}

StagedFolder::StagedFolder(std::string dir, bool replace) : dir_(std::move(dir)) {
  while (dir_.size() > 1 && dir_.back() == '/') dir_.pop_back();
  if (fs::exists(dir_) && !replace)
    throw Error("output folder '" + dir_ + "' already exists (pass --force to replace it)");
  staging_ = staging_path(dir_);
  fs::remove_all(staging_);
  std::error_code ec;
  fs::create_directories(staging_, ec);
  if (ec) throw Error("cannot create '" + staging_ + "': " + ec.message());
}

StagedFolder::~StagedFolder() {
  if (!committed_) {
    std::error_code ec;
    fs::remove_all(staging_, ec);
  }
}

void StagedFolder::commit() {
  fs::remove_all(dir_);
  fs::rename(staging_, dir_);
  committed_ = true;
}

}  // namespace nova::cli

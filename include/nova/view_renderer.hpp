#pragma once
// Inference: renders any camera of a trained run at any time, and compositions of object
// instances (which object NeRF, where, at which time) over the static scene, with hard
// blending. Rays run in chunks through cached view graphs (one per NeRF layout).
#include <array>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "nova/checkpoint.hpp"
#include "nova/occupancy.hpp"
#include "nova/compose_spec.hpp"
#include "nova/executor.hpp"
#include "nova/nova_graphs.hpp"
#include "nova/train_config.hpp"

namespace nova {

// What a run folder holds for inference.
struct RunFiles {
  std::string dir;
  TrainConfig config;
  std::string scene;  // the scene folder it trained on
  Checkpoint checkpoint;
};
// Reads RUN/config.ini and RUN/checkpoint.bin; Error (exit 2) naming what is missing or bad.
RunFiles read_run(const std::string& dir);

struct PlacedInstance {
  int object = 1;     // 1..K
  double time = 0;    // the object NeRF's time input
  std::array<double, 12> world_to_object{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
};
// The scene as trained: every object k at `time`, where it was.
std::vector<PlacedInstance> scene_instances(int objects, double time);
// A compose-spec instance: its placement inverted.
PlacedInstance placed_instance(const ComposeInstance& inst);

struct ViewRequest {
  Camera camera;
  bool background = true;
  std::vector<PlacedInstance> instances;
  bool hard_blend = true;
};

struct ViewImage {
  int width = 0, height = 0;
  std::vector<float> rgb;                 // H*W*3 in [0, 1]
  std::vector<float> depth, acc;          // H*W (depth: NDC t or metric, as the rays)
  std::vector<std::vector<float>> masks;  // per NeRF drawn (background first), H*W each
};

class ViewRenderer {
 public:
  // `chunk_rays` 0: chosen from the network width (about 2^24 activations per layer).
  ViewRenderer(Runtime& rt, const TrainConfig& config, const RayGeometry& geometry,
               const Checkpoint& checkpoint, int chunk_rays = 0);
  ~ViewRenderer();
  ViewImage render(const ViewRequest& request);
  int num_objects() const { return geometry_.num_objects; }
  bool has_objects() const { return has_objects_; }
  int chunk_rays() const { return chunk_rays_; }
  // Whether renders skip empty space (the run trained with occupancy grids and saved them).
  bool skips_empty_space() const { return grids_ != nullptr; }
  // Renders every sample even when the run has occupancy grids (the reference for tests).
  void set_skip_empty_space(bool on);

 private:
  struct Cached;
  Cached& graph_for(bool background, int instances, int rays, bool hard_blend);

  Runtime& rt_;
  TrainConfig config_;
  RayGeometry geometry_;
  const Checkpoint& checkpoint_;
  bool has_objects_ = false;
  int chunk_rays_ = 0;
  std::shared_ptr<std::vector<OccupancyGrid>> grids_, saved_grids_;
  std::map<std::tuple<bool, int, int, bool>, std::unique_ptr<Cached>> graphs_;
};

}  // namespace nova

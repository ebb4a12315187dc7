#pragma once
// Inference: renders any camera of a trained run at any time, and compositions of object
// instances (which object NeRF, where, at which time) over the static scene, with hard
// blending. Rays run in chunks through cached view graphs (one per NeRF layout), skipping
// empty space (occupancy grids) and stopping early (EarlyTermination).
#include <array>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <vector>

#include "nova/model/checkpoint.hpp"
#include "nova/model/occupancy_estimator.hpp"
#include "nova/model/compose_spec.hpp"
#include "nova/model/object_centre.hpp"
#include "nova/graph/executor.hpp"
#include "nova/model/model_config.hpp"
#include "nova/model/field_graphs.hpp"

namespace nova {

struct PlacedInstance {
  int object = 1;     // 1..K
  double time = 0;    // the object NeRF's time input
  std::array<double, 12> world_to_object{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
};
// The scene as trained: every object k at `time`, where it was.
std::vector<PlacedInstance> scene_instances(int objects, double time);
// A compose-spec instance: its placement inverted. The instance must have its pivot (a
// renderer decides a missing one: ViewRenderer::place).
PlacedInstance placed_instance(const ComposeInstance& inst);
// The same, turning about `pivot` whatever the instance says.
PlacedInstance placed_instance(const ComposeInstance& inst, const std::array<double, 3>& pivot);

// What a compose-spec instance turns about, and where that came from: the spec's pivot=, the
// object's centre at the instance's time (its density), or the scene origin where the object
// has no density at that time.
struct InstancePivot {
  enum class From { Spec, Density, Origin };
  std::array<double, 3> pivot{0, 0, 0};
  From from = From::Spec;
};
const char* pivot_source_name(InstancePivot::From from);  // "spec", "density", "origin"

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

// Early ray termination: volume rendering with one shared transmittance splits along depth,
// C = C_1 + T_1 C_2 (C_1 the composite of samples [0, s), C_2 that of [s, S) with the
// transmittance restarted at 1, T_1 what is left after s; the same for depth, acc and the
// masks). A render runs one pass per segment between the `checks` and adds a segment only
// for rays whose transmittance is still >= `below`, so a stopped ray loses at most `below`
// of every colour channel, acc and mask (and `below` times the far depth of its depth).
struct EarlyTermination {
  bool on = true;
  float below = 1e-4f;
  // Sample indices (ascending, in (0, S)) where the transmittance is checked; empty: S / 2.
  std::vector<int> checks;
  // Passes pay only where rays stop: each extra pass costs the dense part of a graph run (ray
  // samples, the pack test, compositing) whatever it saves, so a hazy view renders slower in
  // passes. Per view, the first chunk is a probe (in passes); while the last probe stopped
  // fewer than `pays_from` of its rays, the next `probe_every` chunks run in one pass (the
  // render without termination, bit for bit where the run has grids), then another probe.
  // 0.15: `nova-bench view` measured the break-even at 0.12-0.23 on 2 CPU cores
  // (docs/known-issues.md); 0: every chunk in passes.
  float pays_from = 0.15f;
  int probe_every = 4;
};

// What the last render did (its pixels; a graph without packing also evaluates the padded
// rays of a last chunk, and `evaluated` counts those).
struct RenderStats {
  size_t rays = 0;
  size_t terminated = 0;  // rays that stopped before their last segment
  size_t passes = 0;      // graph runs
  // Field evaluations (a sample of one NeRF), and those a render without any skip would run.
  size_t evaluated = 0, samples = 0;
  // Of `evaluated`, those after the first check in chunks run in passes (`nova-bench view`
  // weighs what stopping can save by them).
  size_t late = 0;
  std::vector<uint8_t> split;  // per chunk of rays: 1 if it ran in passes, 0 in one
};

class ViewRenderer {
 public:
  // `chunk_rays` 0: chosen from the network width (about 2^24 activations per layer).
  ViewRenderer(Runtime& rt, const ModelConfig& config, const RayGeometry& geometry,
               const Checkpoint& checkpoint, int chunk_rays = 0);
  ~ViewRenderer();
  ViewImage render(const ViewRequest& request);
  int num_objects() const { return geometry_.num_objects; }
  bool has_objects() const { return has_objects_; }
  int chunk_rays() const { return chunk_rays_; }
  // Whether renders skip empty space (the run trained with occupancy grids and saved them).
  bool skips_empty_space() const { return grids_ != nullptr; }
  // Called after every chunk of a render with the view's rays done and in all (for progress
  // lines of long renders); empty: none.
  void set_progress(std::function<void(size_t done, size_t total)> progress) { progress_ = std::move(progress); }
  // Renders every sample even when the run has occupancy grids (the reference for tests).
  void set_skip_empty_space(bool on);
  // On by default; off renders every sample of every ray (the reference for tests).
  void set_early_termination(bool on) { termination_.on = on; }
  void set_early_termination(const EarlyTermination& t);
  const EarlyTermination& early_termination() const { return termination_; }
  const RenderStats& last_stats() const { return stats_; }

  // The centre of object `object` (1..K) at `time` (object_centre.hpp): the object NeRF's
  // density probed at the centres of the cells its occupancy grid marks occupied (what a
  // render draws of it), or of every cell of a kCentreProbeResolution^3 grid over the field's
  // box where the run has no grid for it or renders skip nothing (set_skip_empty_space). In world (scene processed) coordinates, the compose spec's. Not found where the
  // object has no density at that time, or the run has no trained object NeRFs. Cached per
  // (object, time) until set_skip_empty_space changes what is probed; the same run gives
  // the same bits.
  const Centroid& object_centre(int object, double time);
  static constexpr int kCentreProbeResolution = 64;
  // The instance's pivot: its own, else its object's centre at its time, else the origin.
  InstancePivot pivot_for(const ComposeInstance& inst);
  PlacedInstance place(const ComposeInstance& inst) { return placed_instance(inst, pivot_for(inst).pivot); }

 private:
  // A rigid object's motion rows in the checkpoint (motion.hpp), and an instance's
  // world -> canonical transform (its placement, then that motion at its time).
  const float* motion_rows(int object) const;
  std::array<double, 12> object_transform(const PlacedInstance& i) const;

  struct Cached;
  struct Probe;
  Cached& graph_for(bool background, int instances, int rays, bool hard_blend, bool packed);
  // Segment bounds [0, checks..., S] of the passes (just [0, S] when termination is off).
  std::vector<size_t> segments() const;

  Runtime& rt_;
  ModelConfig config_;
  RayGeometry geometry_;
  const Checkpoint& checkpoint_;
  bool has_objects_ = false;
  int chunk_rays_ = 0;
  std::function<void(size_t, size_t)> progress_;
  std::unique_ptr<OccupancyEstimator> saved_;  // the checkpoint's grids (null: none)
  std::shared_ptr<const std::vector<OccupancyGrid>> grids_, saved_grids_;  // grids_: null while skipping is off
  EarlyTermination termination_;
  RenderStats stats_;
  std::map<std::tuple<bool, int, int, bool, bool>, std::unique_ptr<Cached>> graphs_;
  std::unique_ptr<Probe> probe_;
  std::map<std::pair<int, double>, Centroid> centres_;
};

}  // namespace nova

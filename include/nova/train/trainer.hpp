#pragma once
// Training a NOVA scene headless: static pretraining on background pixels, then joint
// training of the static and the object NeRFs with novel-view augmentation. Writes into a
// run folder: config.ini (the effective configuration), metrics.jsonl (one record per
// logged step) and checkpoint.bin (atomic; weights, Adam moments, step and random state,
// so that a resumed run continues bit for bit as if it had not stopped).
#include <functional>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "nova/model/checkpoint.hpp"
#include "nova/graph/executor.hpp"
#include "nova/graph/distributed.hpp"
#include "nova/model/occupancy_estimator.hpp"
#include "nova/train/disparity_fit.hpp"
#include "nova/train/motion_init.hpp"
#include "nova/train/optim.hpp"
#include "nova/train/run_folder.hpp"
#include "nova/runtime/runtime.hpp"
#include "nova/model/scene.hpp"
#include "nova/train/step_graphs.hpp"
#include "nova/train/train_config.hpp"

namespace nova {

struct TrainProgress {
  long step = 0, total = 0;  // steps done, steps of the whole run
  std::string phase;         // "pretrain" or "joint"
  double loss = 0, psnr = 0, lr = 0;
  double rays_per_s = 0, seconds = 0, eta_seconds = 0;
  std::vector<std::pair<std::string, double>> terms;
  bool augmented = false;  // whether the logged step was an augmented one
  // With occupancy grids: the fraction of samples the logged step ran an MLP on (static and
  // object samples together), and each grid's occupied fraction; -1 / empty without.
  double kept = -1;
  std::vector<double> occupied;
};

class Trainer {
 public:
  // `scene` must outlive the trainer. The run folder is created when missing. With a
  // `reducer` of N > 1 ranks (distributed.hpp; it must outlive the trainer) this rank trains
  // on its share of every step's rays (config.rays must divide by N) and only rank 0 writes
  // config.ini, metrics.jsonl and checkpoints.
  Trainer(Runtime& rt, const Scene& scene, const TrainConfig& config, std::string run_dir,
          GradientReducer* reducer = nullptr);
  ~Trainer();

  // Restores RUN/checkpoint.bin: Error when it is missing, corrupt, or written for other
  // networks or another number of objects. RUN/config.ini is rewritten (this configuration)
  // only once the checkpoint is accepted, else by run().
  void resume();
  // Trains up to `until_step` (the configuration's total when < 0), logging every
  // log_every steps and checkpointing every checkpoint_every steps and at the end.
  void run(const std::function<void(const TrainProgress&)>& progress = {}, long until_step = -1);

  // Time every op (the runtime must be created with profiling on); profile_table() then
  // holds the joint (or, before it, the pretraining) graph's per-op times.
  void set_profile(bool on) { profile_ = on; }
  // Rigid objects: called once with the start initial_motion finds (trajectories, boxes,
  // radii) before the joint phase's first step, and may change it: a bench that starts from
  // a known trajectory. Not called on a resume, which loads the trained motion.
  void set_motion_start_hook(std::function<void(MotionStart&)> hook) { motion_start_hook_ = std::move(hook); }
  std::string profile_table() const { return exec_ ? exec_->profile_table() : std::string(); }
  // Forgets the timings so far (e.g. those of warm-up steps, which include kernel builds).
  void reset_profile() {
    if (exec_) exec_->reset_timings();
  }

  long step() const { return step_; }
  // The scene's ray geometry (NDC or metric, its box): what a motion start hook needs to place
  // objects' boxes (object_box_row) for trajectories of its own.
  const RayGeometry& geometry() const { return geometry_; }
  // Device bytes of the current phase's step: the planned activation arena, the parameters,
  // their gradients and Adam's two moments (0 before the first step).
  size_t device_bytes() const;
  long total_steps() const;
  const std::string& run_dir() const { return run_.dir(); }
  // The current state as a checkpoint (what run() writes).
  Checkpoint checkpoint();

 private:
  bool joint_phase(long step) const;
  void ensure_phase();           // the phase of the current step
  void ensure_phase(bool joint);  // that phase's graph and executor
  void train_step(bool log, TrainProgress& p);
  void write_checkpoint_now();
  // object-box-bounded: the objects' occupancy grids end at their boxes (rows of objects.box).
  void bound_objects(const std::vector<float>& boxes);
  void write_config();
  void maybe_update_occupancy(long phase_step);

  Runtime& rt_;
  const Scene& scene_;
  TrainConfig config_;
  RunFolder run_;
  RayGeometry geometry_;
  std::mt19937 rng_;
  long step_ = 0;
  std::unique_ptr<StepGraph> graph_;
  std::unique_ptr<Executor> exec_;
  std::unique_ptr<Adam> adam_;
  bool graph_joint_ = false;
  bool profile_ = false;
  std::function<void(MotionStart&)> motion_start_hook_;
  bool config_written_ = false;
  std::vector<std::vector<std::vector<uint32_t>>> regions_;  // per frame, cached
  std::vector<std::vector<float>> surfaces_;  // per frame with free_space_scene_fit (surface_map)
  std::optional<DisparityFit> disparity_fit_;  // fit_disparity, once computed for surfaces_
  // Empty-space skipping (config_.occupancy): the grids of the static and object NeRFs.
  std::unique_ptr<OccupancyEstimator> occupancy_;  // with TrainConfig::occupancy
  GradientReducer* reducer_ = nullptr;
  size_t ranks() const { return reducer_ ? static_cast<size_t>(reducer_->size()) : 1; }
  bool writes_files() const { return !reducer_ || reducer_->rank() == 0; }
  RaySlice ray_slice() const;
  void reduce_gradients();
  void reduce_progress(TrainProgress& p, double& mse);
};

}  // namespace nova

#pragma once
// One owner of a model's empty-space skipping, in the spirit of nerfacc's OccGridEstimator:
// the occupancy grids (one per NeRF, occupancy.hpp), their update schedule, the density probe
// that updates them, their checkpoint arrays, and the grids the pack ops test samples
// against. A trainer makes one with fresh grids and updates; a renderer takes one from a
// checkpoint and only reads it.
#include <memory>
#include <vector>

#include "nova/model/checkpoint.hpp"
#include "nova/graph/executor.hpp"
#include "nova/model/field_graphs.hpp"
#include "nova/sampling/occupancy.hpp"

namespace nova {

// nerfacc's schedule: nothing is skipped during a phase's first `warmup` steps, then every
// cell is probed once, and a random 1/16 of them every `every` steps.
struct OccupancySchedule {
  int warmup = 256;
  int every = 16;
};

class OccupancyEstimator {
 public:
  // Fresh grids (every cell occupied until probed) of a model of 1 + `objects` NeRFs over
  // the field's box [-bound, bound]^3.
  OccupancyEstimator(int objects, int resolution, float bound, float alpha);
  ~OccupancyEstimator();
  // The grids a checkpoint holds (arrays occupancy.k), or null when it has none. A checkpoint
  // of static pretraining holds the static grid alone: object NeRFs then get one-cell grids
  // that skip nothing.
  static std::unique_ptr<OccupancyEstimator> from_checkpoint(const Checkpoint& ck, int objects, float bound,
                                                             float alpha);

  // Training: probes the field of `source` (an executor of a graph built by the same field
  // builders; weights copied by name) when the schedule says so after `phase_step` steps of
  // a phase. Pretraining keeps only the static grid current (the object NeRFs are untrained),
  // the joint phase all of them. Draws come from a generator seeded by (seed, step), so that
  // resume (which restores the grids) continues exactly. `times`: the frame times object
  // fields are probed at.
  void enable_updates(Runtime& rt, const FieldConfig& field, const RayGeometry& geometry, std::vector<double> times,
                      OccupancySchedule schedule, int points = 16384);
  void maybe_update(Executor& source, long phase_step, bool objects, unsigned seed, long step);

  // Object NeRF k's grid holds no occupied cell outside its box (object-box-bounded):
  // `boxes` [K * 6] are the rows of the objects.box parameter (centre, log of the inverse
  // half-size; box_coordinates), widened by `margin` (field units) on every side.
  void bound_objects(const std::vector<float>& boxes, float margin);
  // The grids' densities as checkpoint arrays, and back (the grids' sizes must match).
  void save(Checkpoint& ck) const;
  void restore(const Checkpoint& ck);

  std::shared_ptr<const std::vector<OccupancyGrid>> grids() const { return grids_; }
  const OccupancyGrid& grid(size_t k) const { return grids_->at(k); }
  size_t size() const { return grids_->size(); }
  std::vector<double> occupied_fractions() const;

 private:
  explicit OccupancyEstimator(std::vector<OccupancyGrid> grids);
  struct Updater;
  void update(Executor& source, bool objects, bool full, unsigned seed, long step);

  std::shared_ptr<std::vector<OccupancyGrid>> grids_;
  OccupancySchedule schedule_;
  std::unique_ptr<Updater> updater_;
};

}  // namespace nova

#pragma once
// Keeps a model's occupancy grids (occupancy.hpp) current from the density alone: it probes
// the static field, and each object field at random frame times, at random points of a
// subset of the cells (all cells on the first update), with the weights of the training
// executor copied over by name.
#include <memory>
#include <random>
#include <vector>

#include "nova/executor.hpp"
#include "nova/nova_graphs.hpp"
#include "nova/occupancy.hpp"

namespace nova {

class OccupancyUpdater {
 public:
  // `times`: the frame times object fields are probed at.
  OccupancyUpdater(Runtime& rt, const FieldConfig& field, const RayGeometry& geometry,
                   std::vector<double> times, int points = 16384);
  ~OccupancyUpdater();

  // Updates grids[0] (static) and, when `objects`, grids[1..K] from the weights of `source`
  // (an executor of a graph built by the same field builders, copied by name). `full`: every cell, else
  // 1/16 of them. Object cells are probed at two random times per visit.
  void update(Executor& source, std::vector<OccupancyGrid>& grids,
              bool objects, bool full, std::mt19937& rng);

 private:
  Runtime& rt_;
  FieldConfig field_;
  RayGeometry geometry_;
  std::vector<double> times_;
  int points_;
  std::unique_ptr<DensityGraph> graph_;
  std::unique_ptr<Executor> exec_;
  bool graph_objects_ = false;
};

// The grids of a model with `objects` object NeRFs over the field's box.
std::vector<OccupancyGrid> make_occupancy_grids(int objects, int resolution, float bound, float alpha);

}  // namespace nova

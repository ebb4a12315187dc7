// OccupancyEstimator (occupancy_estimator.hpp): fresh and saved grids, the schedule, and the
// density probe that keeps the grids current.
#include "nova/model/occupancy_estimator.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include "nova/runtime/error.hpp"
#include "nova/render/render_composite.hpp"

namespace nova {

// The probe: a density graph of the model's fields on `points` positions at a time.
struct OccupancyEstimator::Updater {
  Runtime& rt;
  FieldConfig field;
  RayGeometry geometry;
  std::vector<double> times;
  int points;
  std::unique_ptr<DensityGraph> graph;
  std::unique_ptr<Executor> exec;
  bool graph_objects = false;
};

namespace {

// Which cells to probe: all of them, or a random 1/16 (each cell about every 16 updates).
std::vector<size_t> pick_cells(size_t cells, bool full, std::mt19937& rng) {
  std::vector<size_t> v;
  if (full) {
    v.resize(cells);
    for (size_t i = 0; i < cells; ++i) v[i] = i;
    return v;
  }
  const size_t n = std::max<size_t>(1, cells / 16);
  v.reserve(n);
  for (size_t i = 0; i < n; ++i) v.push_back(static_cast<size_t>(rng() % cells));
  return v;
}

float unit(std::mt19937& rng) { return static_cast<float>(rng() >> 8) * (1.0f / 16777216.0f); }

}  // namespace

OccupancyEstimator::OccupancyEstimator(int objects, int resolution, float bound, float alpha)
    : OccupancyEstimator(std::vector<OccupancyGrid>(static_cast<size_t>(1 + objects), OccupancyGrid(resolution, bound, alpha))) {}

OccupancyEstimator::OccupancyEstimator(std::vector<OccupancyGrid> grids)
    : grids_(std::make_shared<std::vector<OccupancyGrid>>(std::move(grids))) {}

OccupancyEstimator::~OccupancyEstimator() = default;

std::unique_ptr<OccupancyEstimator> OccupancyEstimator::from_checkpoint(const Checkpoint& ck, int objects, float bound,
                                                                        float alpha) {
  std::vector<OccupancyGrid> grids;
  for (int k = 0; k <= objects; ++k) {
    const std::string name = occupancy_array_name(k);
    const auto it = std::find_if(ck.arrays.begin(), ck.arrays.end(), [&](const CheckpointArray& a) { return a.name == name; });
    if (it == ck.arrays.end()) break;
    if (it->shape.size() != 3 || it->shape[0] != it->shape[1] || it->shape[1] != it->shape[2])
      throw Error("checkpoint array '" + name + "' is not a cubic occupancy grid");
    OccupancyGrid g(static_cast<int>(it->shape[0]), bound, alpha);
    g.density = it->values;
    g.refresh();
    grids.push_back(std::move(g));
  }
  if (grids.empty()) return nullptr;
  while (static_cast<int>(grids.size()) <= objects) grids.emplace_back(1, bound, alpha);
  return std::unique_ptr<OccupancyEstimator>(new OccupancyEstimator(std::move(grids)));
}

void OccupancyEstimator::enable_updates(Runtime& rt, const FieldConfig& field, const RayGeometry& geometry,
                                        std::vector<double> times, OccupancySchedule schedule, int points) {
  if (times.empty()) times.push_back(0.0);
  schedule_ = schedule;
  updater_.reset(new Updater{rt, field, geometry, std::move(times), points, nullptr, nullptr, false});
}

void OccupancyEstimator::bound_objects(const std::vector<float>& boxes, float margin) {
  std::vector<OccupancyGrid>& gs = *grids_;
  if (boxes.size() != 6 * (gs.size() - 1))
    throw Error("occupancy: " + std::to_string(boxes.size()) + " box numbers for " + std::to_string(gs.size() - 1) +
                    " objects",
                kExitInternal);
  for (size_t k = 1; k < gs.size(); ++k) {
    const float* b = boxes.data() + (k - 1) * 6;
    std::vector<float> support(6);
    for (size_t d = 0; d < 3; ++d) {
      const float half = std::exp(-b[3 + d]) + margin;
      support[d] = b[d] - half;
      support[3 + d] = b[d] + half;
    }
    gs[k].set_support(std::move(support));
  }
}

void OccupancyEstimator::maybe_update(Executor& source, long phase_step, bool objects, unsigned seed, long step) {
  if (!updater_ || phase_step < schedule_.warmup) return;
  const long since = phase_step - schedule_.warmup;
  if (since % schedule_.every != 0) return;
  update(source, objects, since == 0, seed, step);
}

void OccupancyEstimator::update(Executor& source, bool objects, bool full, unsigned seed, long step) {
  Updater& up = *updater_;
  std::vector<OccupancyGrid>& gs = *grids_;
  // Its own generator, seeded by the step: resume restores the grids, not another stream.
  std::mt19937 rng(seed * 2654435761u + static_cast<unsigned>(step));
  const int K = objects ? static_cast<int>(gs.size()) - 1 : 0;
  if (!up.graph || up.graph_objects != (K > 0)) {
    up.exec.reset();
    up.graph = build_density_graph(up.field, up.geometry, K, up.points);
    up.exec = std::make_unique<Executor>(up.rt, up.graph->graph);
    up.graph_objects = K > 0;
  }
  copy_parameters(*up.exec, source);

  const size_t P = static_cast<size_t>(up.points);
  // Static cells once each; object cells twice, at two random times.
  const std::vector<size_t> s_cells = pick_cells(gs[0].cells(), full, rng);
  std::vector<std::vector<size_t>> o_cells(static_cast<size_t>(K));
  for (int k = 0; k < K; ++k) {
    const auto c = pick_cells(gs[static_cast<size_t>(k + 1)].cells(), full, rng);
    o_cells[static_cast<size_t>(k)] = c;
    o_cells[static_cast<size_t>(k)].insert(o_cells[static_cast<size_t>(k)].end(), c.begin(), c.end());
  }
  size_t chunks = (s_cells.size() + P - 1) / P;
  for (const auto& c : o_cells) chunks = std::max(chunks, (c.size() + P - 1) / P);

  std::vector<float> pos(P * 3), dirs(P * 3, 0.0f), opos(static_cast<size_t>(K) * P * 3),
      otimes(static_cast<size_t>(K) * P);
  for (size_t i = 0; i < P; ++i) dirs[i * 3 + 2] = -1.0f;  // density does not depend on it
  up.exec->set(up.graph->static_viewdirs, dirs);
  for (size_t chunk = 0; chunk < chunks; ++chunk) {
    const size_t first = chunk * P;
    const size_t ns = first < s_cells.size() ? std::min(P, s_cells.size() - first) : 0;
    for (size_t i = 0; i < P; ++i) {
      const float u[3] = {unit(rng), unit(rng), unit(rng)};
      gs[0].point_in(i < ns ? s_cells[first + i] : 0, u, &pos[i * 3]);
    }
    up.exec->set(up.graph->static_positions, pos);
    for (int k = 0; k < K; ++k) {
      const auto& c = o_cells[static_cast<size_t>(k)];
      const size_t n = first < c.size() ? std::min(P, c.size() - first) : 0;
      for (size_t i = 0; i < P; ++i) {
        const float u[3] = {unit(rng), unit(rng), unit(rng)};
        const size_t at = static_cast<size_t>(k) * P + i;
        gs[static_cast<size_t>(k + 1)].point_in(i < n ? c[first + i] : 0, u, &opos[at * 3]);
        otimes[at] = static_cast<float>(up.times[rng() % up.times.size()]);
      }
    }
    if (K > 0) {
      up.exec->set(up.graph->object_positions, opos);
      up.exec->set(up.graph->object_times, otimes);
    }
    up.exec->forward();
    const auto take = [&](const std::vector<float>& raw, size_t offset, size_t n, const size_t* cells,
                          OccupancyGrid& g) {
      std::vector<size_t> cs(cells, cells + n);
      std::vector<float> d(n);
      for (size_t i = 0; i < n; ++i) d[i] = raw[(offset + i) * kRawChannels + kRawSigma];
      g.update(cs, d, 0.95f);
    };
    if (ns > 0) take(up.exec->get(up.graph->static_raw), 0, ns, s_cells.data() + first, gs[0]);
    if (K > 0) {
      const std::vector<float> raw = up.exec->get(up.graph->object_raw);
      for (int k = 0; k < K; ++k) {
        const auto& c = o_cells[static_cast<size_t>(k)];
        const size_t n = first < c.size() ? std::min(P, c.size() - first) : 0;
        if (n > 0) take(raw, static_cast<size_t>(k) * P, n, c.data() + first, gs[static_cast<size_t>(k + 1)]);
      }
    }
  }
  gs[0].refresh();
  for (int k = 1; k <= K; ++k) gs[static_cast<size_t>(k)].refresh();
}

void OccupancyEstimator::save(Checkpoint& ck) const {
  for (size_t k = 0; k < grids_->size(); ++k) {
    const OccupancyGrid& g = (*grids_)[k];
    const size_t r = static_cast<size_t>(g.resolution);
    ck.arrays.push_back({occupancy_array_name(static_cast<int>(k)), {r, r, r}, g.density});
  }
}

void OccupancyEstimator::restore(const Checkpoint& ck) {
  for (size_t k = 0; k < grids_->size(); ++k) {
    OccupancyGrid& g = (*grids_)[k];
    const CheckpointArray& a = ck.array(occupancy_array_name(static_cast<int>(k)));
    if (a.values.size() != g.density.size())
      throw Error("occupancy grid " + std::to_string(k) + " has " + std::to_string(a.values.size()) +
                  " cells in the checkpoint, configured " + std::to_string(g.density.size()));
    g.density = a.values;
    g.refresh();
  }
}

std::vector<double> OccupancyEstimator::occupied_fractions() const {
  std::vector<double> f;
  for (const OccupancyGrid& g : *grids_) f.push_back(g.occupied_fraction());
  return f;
}

}  // namespace nova

#include "nova/occupancy_updater.hpp"

#include <algorithm>
#include <cmath>

#include "nova/error.hpp"
#include "nova/render.hpp"

namespace nova {

std::vector<OccupancyGrid> make_occupancy_grids(int objects, int resolution, float bound, float alpha) {
  return std::vector<OccupancyGrid>(static_cast<size_t>(1 + objects), OccupancyGrid(resolution, bound, alpha));
}

OccupancyUpdater::OccupancyUpdater(Runtime& rt, const FieldConfig& field, const RayGeometry& geometry,
                                   std::vector<double> times, int points)
    : rt_(rt), field_(field), geometry_(geometry), times_(std::move(times)), points_(points) {
  if (times_.empty()) times_.push_back(0.0);
}

OccupancyUpdater::~OccupancyUpdater() = default;

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

void OccupancyUpdater::update(Executor& source, std::vector<OccupancyGrid>& grids,
                              bool objects, bool full, std::mt19937& rng) {
  const int K = objects ? static_cast<int>(grids.size()) - 1 : 0;
  if (!graph_ || graph_objects_ != (K > 0)) {
    exec_.reset();
    graph_ = build_density_graph(field_, geometry_, K, points_);
    exec_ = std::make_unique<Executor>(rt_, graph_->graph);
    graph_objects_ = K > 0;
  }
  copy_parameters(*exec_, source);

  const size_t P = static_cast<size_t>(points_);
  // Static cells once each; object cells twice, at two random times.
  const std::vector<size_t> s_cells = pick_cells(grids[0].cells(), full, rng);
  std::vector<std::vector<size_t>> o_cells(static_cast<size_t>(K));
  for (int k = 0; k < K; ++k) {
    const auto c = pick_cells(grids[static_cast<size_t>(k + 1)].cells(), full, rng);
    o_cells[static_cast<size_t>(k)] = c;
    o_cells[static_cast<size_t>(k)].insert(o_cells[static_cast<size_t>(k)].end(), c.begin(), c.end());
  }
  size_t chunks = (s_cells.size() + P - 1) / P;
  for (const auto& c : o_cells) chunks = std::max(chunks, (c.size() + P - 1) / P);

  std::vector<float> pos(P * 3), dirs(P * 3, 0.0f), opos(static_cast<size_t>(K) * P * 3),
      otimes(static_cast<size_t>(K) * P);
  for (size_t i = 0; i < P; ++i) dirs[i * 3 + 2] = -1.0f;  // density does not depend on it
  exec_->set(graph_->static_viewdirs, dirs);
  for (size_t chunk = 0; chunk < chunks; ++chunk) {
    const size_t first = chunk * P;
    const size_t ns = first < s_cells.size() ? std::min(P, s_cells.size() - first) : 0;
    for (size_t i = 0; i < P; ++i) {
      const float u[3] = {unit(rng), unit(rng), unit(rng)};
      grids[0].point_in(i < ns ? s_cells[first + i] : 0, u, &pos[i * 3]);
    }
    exec_->set(graph_->static_positions, pos);
    for (int k = 0; k < K; ++k) {
      const auto& c = o_cells[static_cast<size_t>(k)];
      const size_t n = first < c.size() ? std::min(P, c.size() - first) : 0;
      for (size_t i = 0; i < P; ++i) {
        const float u[3] = {unit(rng), unit(rng), unit(rng)};
        const size_t at = static_cast<size_t>(k) * P + i;
        grids[static_cast<size_t>(k + 1)].point_in(i < n ? c[first + i] : 0, u, &opos[at * 3]);
        otimes[at] = static_cast<float>(times_[rng() % times_.size()]);
      }
    }
    if (K > 0) {
      exec_->set(graph_->object_positions, opos);
      exec_->set(graph_->object_times, otimes);
    }
    exec_->forward();
    const auto take = [&](const std::vector<float>& raw, size_t offset, size_t n, const size_t* cells,
                          OccupancyGrid& g) {
      std::vector<size_t> cs(cells, cells + n);
      std::vector<float> d(n);
      for (size_t i = 0; i < n; ++i) d[i] = raw[(offset + i) * kRawChannels + kRawSigma];
      g.update(cs, d, 0.95f);
    };
    if (ns > 0) take(exec_->get(graph_->static_raw), 0, ns, s_cells.data() + first, grids[0]);
    if (K > 0) {
      const std::vector<float> raw = exec_->get(graph_->object_raw);
      for (int k = 0; k < K; ++k) {
        const auto& c = o_cells[static_cast<size_t>(k)];
        const size_t n = first < c.size() ? std::min(P, c.size() - first) : 0;
        if (n > 0) take(raw, static_cast<size_t>(k) * P, n, c.data() + first, grids[static_cast<size_t>(k + 1)]);
      }
    }
  }
  grids[0].refresh();
  for (int k = 1; k <= K; ++k) grids[static_cast<size_t>(k)].refresh();
}

}  // namespace nova

#include "nova/model/view_renderer.hpp"

#include <algorithm>

#include "nova/runtime/error.hpp"
#include "nova/model/fields.hpp"
#include "nova/model/object_samples.hpp"
#include "nova/sampling/rays.hpp"
#include "nova/render/render_composite.hpp"

namespace nova {

std::vector<PlacedInstance> scene_instances(int objects, double time) {
  std::vector<PlacedInstance> v;
  for (int k = 1; k <= objects; ++k) v.push_back({k, time, {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0}});
  return v;
}

PlacedInstance placed_instance(const ComposeInstance& inst) {
  return {inst.object, inst.time, invert_rigid(instance_transform(inst))};
}

PlacedInstance placed_instance(const ComposeInstance& inst, const std::array<double, 3>& pivot) {
  return {inst.object, inst.time, invert_rigid(instance_transform(inst, pivot))};
}

const char* pivot_source_name(InstancePivot::From from) {
  switch (from) {
    case InstancePivot::From::Spec: return "spec";
    case InstancePivot::From::Density: return "density";
    case InstancePivot::From::Origin: return "origin";
  }
  return "?";
}

// The density probe of object_centre: one object field (weights of one object at a time)
// on `points` positions at one time each, as the occupancy updater's probe graph.
struct ViewRenderer::Probe {
  static constexpr size_t kPoints = 16384;
  Graph graph;
  Tensor positions, times, raw;
  std::unique_ptr<Executor> exec;
  int loaded = 0;  // the object whose weights the field holds (0: none yet)
};

const Centroid& ViewRenderer::object_centre(int object, double time) {
  const int K = geometry_.num_objects;
  if (object < 1 || object > K)
    throw Error("object " + std::to_string(object) + " does not exist: the run has " + std::to_string(K) +
                " object NeRF(s)");
  const auto key = std::make_pair(object, time);
  if (const auto it = centres_.find(key); it != centres_.end()) return it->second;
  if (!has_objects_) return centres_[key];  // a pretraining checkpoint: no object has density
  const FieldConfig f = scene_field(config_.field, geometry_);
  const float bound = f.occupancy_bound;  // the occupancy grids' cube
  // Which cells to probe: the object's occupied grid cells (its grid holds the maximum over
  // time, so every cell with density at `time` is among them), or all of a default grid.
  const OccupancyGrid* grid = grids_ && static_cast<int>(grids_->size()) > object
                                  ? &(*grids_)[static_cast<size_t>(object)]
                                  : nullptr;
  if (grid && grid->resolution <= 1) grid = nullptr;  // a placeholder: no grid for it
  const int G = grid ? grid->resolution : kCentreProbeResolution;
  const size_t cells = static_cast<size_t>(G) * G * G;
  std::vector<size_t> probe;
  for (size_t c = 0; c < cells; ++c)
    if (!grid || grid->occupied[c]) probe.push_back(c);
  std::vector<float> density(cells, -1.0f);  // unprobed: no density
  if (!probe.empty()) {
    if (!probe_) {
      probe_ = std::make_unique<Probe>();
      const size_t P = Probe::kPoints;
      probe_->positions = probe_->graph.input("object_positions", Shape{P, 3});
      probe_->times = probe_->graph.input("object_times", Shape{P, 1});
      probe_->raw = build_object_fields(probe_->positions, probe_->times, f);
      probe_->graph.keep(probe_->raw);
      probe_->exec = std::make_unique<Executor>(rt_, probe_->graph);
    }
    Probe& pr = *probe_;
    if (pr.loaded != object) {
      for (Tensor p : pr.graph.parameters()) {
        const CheckpointArray& a = checkpoint_.array(p.info().name);
        const size_t slice = a.values.size() / static_cast<size_t>(K);
        pr.exec->set(p, std::vector<float>(a.values.begin() + (object - 1) * slice,
                                           a.values.begin() + object * slice));
      }
      pr.loaded = object;
    }
    const size_t P = Probe::kPoints;
    pr.exec->set(pr.times, std::vector<float>(P, static_cast<float>(time)));
    std::vector<float> pos(P * 3);
    for (size_t first = 0; first < probe.size(); first += P) {
      const size_t n = std::min(P, probe.size() - first);
      for (size_t i = 0; i < P; ++i) {  // a short last chunk repeats its last cell
        const auto q = probe_cell_centre(probe[first + std::min(i, n - 1)], G, bound);
        for (int d = 0; d < 3; ++d) pos[i * 3 + d] = static_cast<float>(q[d]);
      }
      pr.exec->set(pr.positions, pos);
      pr.exec->forward();
      const std::vector<float> raw = pr.exec->get(pr.raw);
      // sigma = ReLU(raw) at inference (render.hpp); density_centroid ignores <= 0.
      for (size_t i = 0; i < n; ++i) density[probe[first + i]] = raw[i * kRawChannels + kRawSigma];
    }
  }
  CentroidOptions o;
  o.ndc = geometry_.ndc;
  o.ax = geometry_.ax;
  o.ay = geometry_.ay;
  o.ndc_near = 1.0;  // the rays' NDC near plane (RayOptions, InstanceOptions)
  Centroid c = density_centroid(density, G, bound, o);
  // A rigid object's field is its canonical shape: its centre at `time` is where the motion
  // puts the canonical centre.
  if (c.found && config_.field.motion == ObjectMotion::Rigid) {
    const MotionOptions mo = motion_options(geometry_);
    c.centre = motion_from_canonical(motion_rows(object), mo.frames, time, c.centre);
  }
  return centres_[key] = c;
}

const float* ViewRenderer::motion_rows(int object) const {
  const CheckpointArray& a = checkpoint_.array("objects.motion");
  const size_t slice = a.values.size() / static_cast<size_t>(geometry_.num_objects);
  return a.values.data() + static_cast<size_t>(object - 1) * slice;
}

std::array<double, 12> ViewRenderer::object_transform(const PlacedInstance& i) const {
  if (config_.field.motion != ObjectMotion::Rigid) return i.world_to_object;
  // world -> the object's scene at its time (the placement) -> its canonical space (motion).
  return compose_rigid(motion_matrix(motion_rows(i.object), motion_options(geometry_).frames, i.time),
                       i.world_to_object);
}

InstancePivot ViewRenderer::pivot_for(const ComposeInstance& inst) {
  if (inst.pivot) return {*inst.pivot, InstancePivot::From::Spec};
  const Centroid& c = object_centre(inst.object, inst.time);
  if (c.found) return {c.centre, InstancePivot::From::Density};
  return {{0, 0, 0}, InstancePivot::From::Origin};
}

// A chunk's early-termination state on the device (kernels/termination.cl).
struct Termination {
  Buffer T, open, was_open, counts, rgb, depth, acc, mask;
};

struct ViewRenderer::Cached {
  std::unique_ptr<ViewGraph> graph;
  std::unique_ptr<Executor> exec;
  std::vector<int> loaded_objects;  // which object's weights each instance slot holds
  Termination termination;
};

ViewRenderer::ViewRenderer(Runtime& rt, const ModelConfig& config, const RayGeometry& geometry,
                           const Checkpoint& checkpoint, int chunk_rays)
    : rt_(rt), config_(config), geometry_(geometry), checkpoint_(checkpoint) {
  if (checkpoint.get("objects") != std::to_string(geometry.num_objects))
    throw Error("the run trained " + checkpoint.get("objects") + " object NeRF(s), the scene has " +
                std::to_string(geometry.num_objects));
  for (const auto& a : checkpoint.arrays)
    if (a.name.rfind(kObjectPrefix, 0) == 0) has_objects_ = true;
  if (config.occupancy) {
    saved_ = OccupancyEstimator::from_checkpoint(checkpoint, geometry.num_objects,
                                                 scene_field(config.field, geometry).occupancy_bound, config.occupancy_alpha);
    if (saved_ && config.field.object_box && config.field.object_box_bounded && geometry.num_objects > 0)
      saved_->bound_objects(checkpoint.array(kObjectBoxName).values, object_box_margin(config.field));
    if (saved_) grids_ = saved_grids_ = saved_->grids();
  }
  const long rows = std::max<long>(config.samples, (1L << 24) / std::max(64, config.field.width));
  chunk_rays_ = chunk_rays > 0 ? chunk_rays : static_cast<int>(std::max<long>(1, rows / config.samples));
}

ViewRenderer::~ViewRenderer() = default;

void ViewRenderer::set_skip_empty_space(bool on) {
  if ((grids_ != nullptr) != (on && saved_grids_ != nullptr)) centres_.clear();  // probed other cells
  grids_ = on ? saved_grids_ : nullptr;
}

void ViewRenderer::set_early_termination(const EarlyTermination& t) {
  int last = 0;
  for (int c : t.checks) {
    if (c <= last || c >= config_.samples)
      throw Error("early termination: checks must rise strictly inside (0, " + std::to_string(config_.samples) +
                  "), got " + std::to_string(c) + " after " + std::to_string(last));
    last = c;
  }
  if (!(t.below >= 0.0f && t.below <= 1.0f))
    throw Error("early termination: the transmittance floor must lie in [0, 1], got " + std::to_string(t.below));
  if (!(t.pays_from >= 0.0f && t.pays_from <= 1.0f))
    throw Error("early termination: the fraction of rays stopped at which passes pay must lie in [0, 1], got " +
                std::to_string(t.pays_from));
  if (t.probe_every < 0)
    throw Error("early termination: chunks between probes must be >= 0, got " + std::to_string(t.probe_every));
  termination_ = t;
}

std::vector<size_t> ViewRenderer::segments() const {
  const size_t S = static_cast<size_t>(config_.samples);
  std::vector<size_t> b{0};
  if (termination_.on) {
    if (termination_.checks.empty() && S >= 2) b.push_back(S / 2);
    for (int c : termination_.checks) b.push_back(static_cast<size_t>(c));
  }
  b.push_back(S);
  return b;
}

ViewRenderer::Cached& ViewRenderer::graph_for(bool background, int instances, int rays, bool hard_blend,
                                              bool packed) {
  auto& slot = graphs_[{background, instances, rays, hard_blend, packed}];
  if (!slot) {
    slot = std::make_unique<Cached>();
    slot->graph = build_view_graph(config_.field, config_.samples, geometry_, rays, background,
                                   instances, hard_blend, packed, uses_object_samples(config_, geometry_, instances));
    slot->exec = std::make_unique<Executor>(rt_, slot->graph->graph);
    slot->loaded_objects.assign(static_cast<size_t>(instances), 0);
    for (Tensor p : slot->graph->graph.parameters())
      if (p.info().name.rfind(kStaticPrefix, 0) == 0) slot->exec->set(p, checkpoint_.array(p.info().name).values);
  }
  return *slot;
}

ViewImage ViewRenderer::render(const ViewRequest& req) {
  const int K = geometry_.num_objects;
  for (const PlacedInstance& inst : req.instances)
    if (inst.object < 1 || inst.object > K)
      throw Error("object " + std::to_string(inst.object) + " does not exist: the run has " + std::to_string(K) +
                  " object NeRF(s) (1.." + std::to_string(K) + ")");
  std::vector<PlacedInstance> instances = req.instances;
  if (!instances.empty() && !has_objects_) {
    if (!req.background)
      throw Error("the run has no trained object NeRFs yet (its checkpoint is from static pretraining)");
    instances.clear();  // a pretraining checkpoint: the background alone
  }
  const int B = static_cast<int>(instances.size());
  // Small views run as one chunk of exactly their pixels (no padded rays).
  const int pixels_in_view = req.camera.width * req.camera.height;
  if (pixels_in_view <= 0) throw Error("the camera has no pixels (" + std::to_string(req.camera.width) + "x" +
                                       std::to_string(req.camera.height) + ")");
  // Terminating needs packed samples even without grids; otherwise the plain graph serves.
  const bool packed = saved_grids_ != nullptr || termination_.on;
  Cached& c = graph_for(req.background, B, std::min(chunk_rays_, pixels_in_view), req.hard_blend, packed);
  ViewGraph& vg = *c.graph;
  // Object weights for each instance slot: slice `object` of the trained [K, ...] arrays.
  std::vector<int> wanted;
  for (const PlacedInstance& i : instances) wanted.push_back(i.object);
  if (wanted != c.loaded_objects) {
    for (Tensor p : vg.graph.parameters()) {
      const std::string& name = p.info().name;
      if (name.rfind(kObjectPrefix, 0) != 0) continue;
      const CheckpointArray& a = checkpoint_.array(name);
      const size_t slice = a.values.size() / static_cast<size_t>(K);
      std::vector<float> v;
      v.reserve(slice * static_cast<size_t>(B));
      for (int o : wanted) v.insert(v.end(), a.values.begin() + (o - 1) * slice, a.values.begin() + o * slice);
      c.exec->set(p, v);
    }
    c.loaded_objects = wanted;
  }
  for (auto& pack : {vg.pack_static, vg.pack_objects})
    if (pack) {
      pack->grids = grids_;
      pack->enabled = grids_ != nullptr;
    }
  if (vg.pack_objects) vg.pack_objects->grid_of_batch = wanted;
  const size_t R = static_cast<size_t>(vg.rays), S = static_cast<size_t>(config_.samples);
  const int N = (req.background ? 1 : 0) + B;
  c.exec->set(vg.cameras, camera_rows(std::vector<Camera>(static_cast<size_t>(N), req.camera)));
  if (B > 0) {
    std::vector<float> xf, times;
    for (const PlacedInstance& i : instances) {
      for (double x : object_transform(i)) xf.push_back(static_cast<float>(x));
      times.push_back(static_cast<float>(i.time));
    }
    c.exec->set(vg.transforms, xf);
    c.exec->set(vg.times, times);
    if (vg.warp.valid()) {
      // Each instance's pivot where its motion and placement put it (object_samples.hpp).
      const std::vector<float>& radius = checkpoint_.array(kObjectRadiusName).values;
      std::vector<Vec3> centres;
      std::vector<double> radii;
      for (const PlacedInstance& i : instances) {
        const Vec3 pivot = motion_pivot(motion_rows(i.object), motion_options(geometry_).frames);
        centres.push_back(apply_rigid(invert_rigid(object_transform(i)), pivot));
        radii.push_back(radius.at(static_cast<size_t>(i.object - 1)));
      }
      c.exec->set(vg.warp, object_sample_warp(config_, centres, radii));
    }
  }

  const int W = req.camera.width, H = req.camera.height;
  const size_t P = static_cast<size_t>(W) * H;
  ViewImage img;
  img.width = W;
  img.height = H;
  img.rgb.resize(P * 3);
  img.depth.resize(P);
  img.acc.resize(P);
  img.masks.assign(static_cast<size_t>(N), std::vector<float>(P));
  stats_ = RenderStats{};
  stats_.rays = P;
  stats_.samples = P * S * static_cast<size_t>(N);
  const std::vector<size_t> passes = segments(), whole{0, S};
  // The adaptive switch (EarlyTermination::pays_from): whether the last probe paid, and the
  // one-pass chunks since. Per view, so that a render depends on its request alone.
  bool pays = true;
  int since_probe = 0;
  // The chunk's state on the device (termination.cl): transmittance, open flags, the
  // composite accumulated over segments; two counts per segment come back to the host.
  Termination& d = c.termination;
  if (!d.T) {
    d.T = rt_.alloc(R * sizeof(float));
    d.open = rt_.alloc(R);
    d.was_open = rt_.alloc(R);
    d.counts = rt_.alloc(2 * sizeof(uint32_t));
    d.rgb = rt_.alloc(R * 3 * sizeof(float));
    d.depth = rt_.alloc(R * sizeof(float));
    d.acc = rt_.alloc(R * sizeof(float));
    d.mask = rt_.alloc(static_cast<size_t>(N) * R * sizeof(float));
  }
  const unsigned rays = static_cast<unsigned>(R), nerfs = static_cast<unsigned>(N);
  std::vector<float> pixels(R * 2), rgb(R * 3), depth(R), acc(R), mask(static_cast<size_t>(N) * R);
  for (size_t first = 0; first < P; first += R) {
    const size_t n = std::min(R, P - first);
    for (size_t r = 0; r < R; ++r) {
      const size_t p = first + std::min(r, n - 1);  // the last chunk repeats its last pixel
      pixels[r * 2] = static_cast<float>(p % static_cast<size_t>(W));
      pixels[r * 2 + 1] = static_cast<float>(p / static_cast<size_t>(W));
    }
    c.exec->set(vg.pixels, pixels);
    // A padded ray is closed from the start: a packed graph then evaluates none of its
    // samples, whether or not rays terminate.
    rt_.launch("termination", "termination_start")
        .arg(d.T).arg(d.open).arg(d.rgb).arg(d.depth).arg(d.acc).arg(d.mask).arg(rays)
        .arg(static_cast<unsigned>(n)).arg(nerfs).run(R);
    const bool split = passes.size() > 2 && (pays || since_probe >= termination_.probe_every);
    since_probe = split ? 0 : since_probe + 1;
    stats_.split.push_back(split);
    const std::vector<size_t>& bounds = split ? passes : whole;
    size_t stopped = 0;
    for (size_t k = 0; k + 1 < bounds.size(); ++k) {
      rt_.launch("termination", "termination_open")
          .arg(d.T).arg(d.open).arg(d.was_open).arg(rays).arg(termination_.below).run(R);
      rt_.launch("termination", "termination_count")
          .arg(d.open).arg(d.was_open).arg(d.counts).arg(rays).arg(static_cast<int>(k == 0)).run(1);
      uint32_t counts[2];
      rt_.download(d.counts.get(), counts, sizeof(counts));
      stopped += counts[1];
      if (counts[0] == 0) break;
      for (auto& pack : {vg.pack_static, vg.pack_objects})
        if (pack) pack->range = {S, bounds[k], bounds[k + 1], d.open.get(), R};
      c.exec->forward();
      ++stats_.passes;
      for (auto& pack : {vg.pack_static, vg.pack_objects})
        if (pack) {
          stats_.evaluated += pack->kept;
          if (k > 0) stats_.late += pack->kept;
        }
      if (!vg.pack_static && !vg.pack_objects) stats_.evaluated += R * S * static_cast<size_t>(N);
      rt_.launch("termination", "termination_accumulate")
          .arg(c.exec->buffer(vg.out.rgb)).arg(c.exec->buffer(vg.out.depth)).arg(c.exec->buffer(vg.out.acc))
          .arg(c.exec->buffer(vg.out.mask)).arg(d.open).arg(d.T).arg(d.rgb).arg(d.depth).arg(d.acc).arg(d.mask)
          .arg(rays).arg(nerfs).run(R);
    }
    rt_.download(d.rgb.get(), rgb.data(), rgb.size() * sizeof(float));
    rt_.download(d.depth.get(), depth.data(), depth.size() * sizeof(float));
    rt_.download(d.acc.get(), acc.data(), acc.size() * sizeof(float));
    rt_.download(d.mask.get(), mask.data(), mask.size() * sizeof(float));
    for (size_t r = 0; r < n; ++r) {
      const size_t p = first + r;
      for (int j = 0; j < 3; ++j) img.rgb[p * 3 + j] = rgb[r * 3 + j];
      img.depth[p] = depth[r];
      img.acc[p] = acc[r];
      for (size_t m = 0; m < static_cast<size_t>(N); ++m) img.masks[m][p] = mask[m * R + r];
    }
    if (progress_) progress_(first + n, P);
    stats_.terminated += stopped;
    if (split) pays = static_cast<double>(stopped) >= static_cast<double>(termination_.pays_from) * static_cast<double>(n);
  }
  return img;
}

}  // namespace nova

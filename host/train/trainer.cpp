#include "nova/train/trainer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "nova/model/object_samples.hpp"
#include "nova/runtime/error.hpp"
#include "nova/train/disparity_edges.hpp"
#include "nova/train/motion_init.hpp"
#include "nova/train/pixel_batch.hpp"
#include "train/metrics_log.hpp"
#include "train/reference_width.hpp"
#include "train/step_batch.hpp"
#include "nova/sampling/rays.hpp"

namespace nova {
namespace fs = std::filesystem;
namespace {

constexpr const char* kFormat = "nova-run-checkpoint 1";

void write_text_atomic(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << text;
    if (!out.flush()) throw Error("cannot write '" + tmp + "'");
  }
  fs::rename(tmp, path);
}

}  // namespace

Trainer::Trainer(Runtime& rt, const Scene& scene, const TrainConfig& config, std::string run_dir,
                 GradientReducer* reducer)
    : rt_(rt), scene_(scene), config_(config), run_(std::move(run_dir)),
      geometry_(ray_geometry(scene)), rng_(config.seed), reducer_(reducer) {
  validate(config_);
  if (ranks() > 1 && static_cast<size_t>(config_.rays) % ranks() != 0)
    throw Error("--rays " + std::to_string(config_.rays) + " cannot be split evenly over " + std::to_string(ranks()) +
                " ranks");
  if (scene.frames.empty()) throw Error("scene '" + scene.source + "' has no frames");
  if (uses_object_samples(config_, geometry_, geometry_.num_objects) &&
      static_cast<size_t>(geometry_.num_objects) > kMaxWarpObjects)
    throw Error("option 'object-samples': samples crowd about at most " + std::to_string(kMaxWarpObjects) +
                " objects, scene '" + scene.source + "' has " + std::to_string(geometry_.num_objects) +
                " (pass --object-samples 0)");
  std::error_code ec;
  fs::create_directories(run_.dir(), ec);
  if (ec) throw Error("cannot create run folder '" + run_.dir() + "': " + ec.message());
  regions_.reserve(scene.frames.size());
  for (const Frame& f : scene.frames) regions_.push_back(pixel_regions(f.masks));
  if (config_.background_gap > 0)
    for (size_t i = 0; i < regions_.size(); ++i) {
      const int width = scene.frames[i].rgb.width;
      const int reach = std::max(1, static_cast<int>(std::lround(config_.background_gap * detail::reference_scale(width))));
      regions_[i][0] = background_apart(regions_[i], width, scene.frames[i].rgb.height, reach);
    }
  // Pretraining draws background pixels (those no object mask claims): some frame must have one.
  if (config_.pretrain_steps > 0 &&
      std::all_of(regions_.begin(), regions_.end(), [](const auto& r) { return r[0].empty(); }))
    throw Error("scene '" + scene.source + "': the object masks cover every pixel of every frame, so the static " +
                "NeRF has no background pixel to pretrain on");
  if (config_.free_space_scene_fit && config_.w_free_space > 0.0f && config_.steps > 0 &&
      geometry_.num_objects > 0 && disparity_usable(geometry_)) {
    const DisparityFit& fit = disparity_fit_.emplace(fit_disparity(scene));
    if (fit.ok) {
      for (const Frame& f : scene.frames) {
        surfaces_.push_back(detail::surface_map(f, fit));
        if (config_.free_space_front) detail::to_object_fronts(surfaces_.back(), f.masks);
      }
    } else {
      // Too little parallax to place the disparity (no depth explains the frames better than a
      // constant): the per-batch fit, which needs no placement, stands in, and the run's
      // config.ini says so.
      config_.free_space_scene_fit = config_.free_space_front = false;
    }
  }
  // The start's nearest depth where the disparity is blurred over the objects' silhouettes
  // (disparity_edges.hpp): decided from the scene alone, so a resume decides the same.
  if (config_.align_depth_auto && config_.align_depth_reach == 0.0f && config_.field.motion == ObjectMotion::Rigid &&
      geometry_.num_objects > 0) {
    const std::optional<double> share = silhouette_step_share(scene);
    if (share && *share < kBlurredStepShare) config_.align_depth_reach = 1.0f;
  }
  if (config_.occupancy) {
    occupancy_ = std::make_unique<OccupancyEstimator>(geometry_.num_objects, config_.occupancy_res,
                                                      scene_field(config_.field, geometry_).occupancy_bound,
                                                      config_.occupancy_alpha);
    std::vector<double> times;
    for (const Frame& f : scene.frames) times.push_back(f.time);
    occupancy_->enable_updates(rt_, config_.field, geometry_, times, {config_.occupancy_warmup, config_.occupancy_every});
  }
}

// Written when training starts or a resume has been accepted, never before: a --resume the
// checkpoint refuses leaves the run's config.ini as it was.
void Trainer::write_config() {
  if (config_written_ || !writes_files()) return;
  write_text_atomic(run_.config_path(), run_config_text(config_, scene_.source));
  config_written_ = true;
}

RaySlice Trainer::ray_slice() const {
  if (ranks() == 1) return {};
  const size_t R = static_cast<size_t>(config_.rays);
  return {R, static_cast<size_t>(reducer_->rank()) * (R / ranks()), reducer_};
}

// The mean over ranks of their gradients: each rank's is of its own rays' mean loss, so the
// mean is the gradient of the whole step's. A term normalised by a statistic of the whole batch
// is the same on every rank; its rank_sum ops' backward sums the gradient of the statistic over
// ranks, so this mean takes each rank's share of it once.
void Trainer::reduce_gradients() {
  const size_t n = exec_->parameter_floats();
  std::vector<float> g(n);
  rt_.download(exec_->gradient_arena(), g.data(), n * sizeof(float));
  reducer_->sum(g);
  const float inv = 1.0f / static_cast<float>(ranks());
  for (float& v : g) v *= inv;
  rt_.upload(exec_->gradient_arena(), g.data(), n * sizeof(float));
}

// Loss, terms, skipped samples and the PSNR's mse as the means over ranks.
void Trainer::reduce_progress(TrainProgress& p, double& mse) {
  std::vector<float> v{static_cast<float>(p.loss), static_cast<float>(p.kept), static_cast<float>(mse)};
  for (auto& [name, t] : p.terms) v.push_back(static_cast<float>(t));
  reducer_->sum(v);
  const double inv = 1.0 / static_cast<double>(ranks());
  p.loss = v[0] * inv;
  if (p.kept >= 0) p.kept = v[1] * inv;
  mse = v[2] * inv;
  for (size_t i = 0; i < p.terms.size(); ++i) p.terms[i].second = v[3 + i] * inv;
}

Trainer::~Trainer() = default;

size_t Trainer::device_bytes() const {
  return exec_ ? exec_->plan().peak_bytes + 4 * exec_->parameter_floats() * sizeof(float) : 0;
}

long Trainer::total_steps() const {
  return static_cast<long>(config_.pretrain_steps) + static_cast<long>(config_.steps);
}

// A run without joint steps stays in pretraining to its end, so its last checkpoint holds
// the static NeRF alone rather than untrained object NeRFs a renderer would draw.
bool Trainer::joint_phase(long step) const {
  return geometry_.num_objects > 0 && config_.steps > 0 && step >= config_.pretrain_steps;
}

// Builds the graph of the current step's phase; on entering the joint phase the static
// NeRF's weights move over from pretraining and a fresh Adam starts (the phases have
// their own optimisers, as the reference's pretraining).
void Trainer::ensure_phase() { ensure_phase(joint_phase(step_)); }

void Trainer::ensure_phase(bool joint) {
  if (exec_ && graph_joint_ == joint) return;
  TrainConfig local = config_;
  local.rays = config_.rays / static_cast<int>(ranks());
  std::unique_ptr<StepGraph> g = joint ? build_joint_graph(local, geometry_, ray_slice())
                                       : build_pretrain_graph(local, geometry_, ray_slice());
  ExecutorOptions eo;
  eo.seed = config_.seed;
  eo.profile = profile_;
  auto e = std::make_unique<Executor>(rt_, g->graph, eo);
  if (exec_) copy_parameters(*e, *exec_, kStaticPrefix);
  // Rigid objects start where their masks and the disparity put them, placed by the static
  // NeRF that pretraining made: at the joint phase's first step only (a resume loads the
  // trained motion instead).
  if (g->motion.valid() && step_ == config_.pretrain_steps) {
    AlignmentOptions align;
    align.depth_reach_px = config_.align_depth_reach;
    align.consistency = config_.align_consistency;
    align.bridge_ratio = config_.align_bridge;
    align.silhouette_turns = config_.align_silhouette;
    MotionStart start = initial_motion(rt_, scene_, geometry_, config_.field, config_.samples, exec_ ? *exec_ : *e,
                                       disparity_fit_ ? &*disparity_fit_ : nullptr, align);
    if (motion_start_hook_) {
      const size_t rows = start.rows.size(), boxes = start.boxes.size(), radii = start.radii.size();
      motion_start_hook_(start);
      if (start.rows.size() != rows || start.boxes.size() != boxes || start.radii.size() != radii)
        throw Error("the motion start hook changed the start's sizes", kExitInternal);
    }
    e->set(g->motion, start.rows);
    for (Tensor p : g->graph.parameters()) {
      if (p.info().name == kObjectBoxName) e->set(p, start.boxes);
      if (p.info().name == kObjectRadiusName) e->set(p, start.radii);
    }
    bound_objects(start.boxes);
  }
  exec_.reset();
  graph_ = std::move(g);
  exec_ = std::move(e);
  for (auto& pack : {graph_->pack_static, graph_->pack_objects})
    if (pack) pack->grids = occupancy_ ? occupancy_->grids() : nullptr;
  adam_ = std::make_unique<Adam>(rt_, exec_->parameter_floats(), config_.adam);
  if (graph_->motion.valid())
    adam_->scale_range(exec_->parameter_offset(graph_->motion), graph_->graph.tensor(graph_->motion.id).shape.numel(),
                       config_.lr_motion);
  graph_joint_ = joint;
}

void Trainer::train_step(bool log, TrainProgress& p) {
  ensure_phase();
  const TrainConfig& c = config_;
  const bool joint = graph_joint_;
  const long phase_step = joint ? step_ - c.pretrain_steps : step_;
  size_t R = static_cast<size_t>(c.rays);  // this rank's rays once the batch is drawn
  const int N = graph_->nerfs;

  detail::StepBatch drawn = detail::draw_step_batch(scene_, regions_, c, joint, phase_step, N,
                                                   graph_->target_nerf_rgb.valid(), rng_);
  const Frame& frame = scene_.frames[drawn.frame];
  const bool augmented = drawn.augmented;
  PixelBatch& batch = drawn.pixels;
  const std::vector<Camera>& cameras = drawn.cameras;

  if (ranks() > 1) {  // this rank's share of the step's rays
    const size_t n = R / ranks();
    batch = detail::slice_batch(batch, R, ray_slice().first_ray, n);
    R = n;
  }
  graph_->draws->value = static_cast<uint64_t>(step_);
  exec_->set(graph_->pixels, batch.pixels);
  exec_->set(graph_->cameras, camera_rows(cameras));
  exec_->set(graph_->target_rgb, batch.rgb);
  if (graph_->target_depth.valid()) {
    detail::DepthTargets d = detail::depth_targets(frame, batch, R, augmented);
    // Before depth_start the depth term has no valid ray: it is 0 and sends no gradient.
    if (!joint && phase_step < c.depth_start) std::fill(d.valid.begin(), d.valid.end(), 0.0f);
    exec_->set(graph_->target_depth, d.target);
    exec_->set(graph_->depth_valid, d.valid);
    if (graph_->free_space_surface.valid())
      exec_->set(graph_->free_space_surface,
                 detail::values_at_pixels(surfaces_.at(drawn.frame), frame.disparity.width, batch, R));
    if (graph_->depth_weight.valid())
      exec_->set(graph_->depth_weight, std::vector<float>{static_cast<float>(c.depth_weight_at(phase_step))});
  }
  if (graph_->target_nerf_rgb.valid())
    exec_->set(graph_->target_nerf_rgb, detail::nerf_rgb_targets(frame, drawn.nerf_images, batch, N, R));
  if (joint) {
    exec_->set(graph_->target_masks, batch.masks);
    exec_->set(graph_->times, std::vector<float>(static_cast<size_t>(scene_.num_objects), static_cast<float>(frame.time)));
    if (graph_->level_window.valid()) {
      const HashGridConfig& h = object_hash_config(config_.field);
      exec_->set(graph_->level_window,
                 level_window(h.levels, h.features, static_cast<double>(phase_step) / c.canonical_coarse_to_fine));
    }
  }
  exec_->forward();
  exec_->backward();
  if (ranks() > 1) reduce_gradients();
  const float lr = ExponentialDecay{c.lr, c.lr_decay, static_cast<double>(c.lr_decay_steps)}(phase_step);
  adam_->step(exec_->parameter_arena(), exec_->gradient_arena(), lr);
  ++step_;
  maybe_update_occupancy(phase_step + 1);

  if (log) {
    p.phase = joint ? "joint" : "pretrain";
    p.loss = exec_->loss();
    p.lr = lr;
    p.augmented = augmented;
    p.terms.clear();
    for (auto& [name, t] : graph_->terms) p.terms.emplace_back(name, exec_->get(t).at(0));
    if (occupancy_) {
      size_t kept = 0, tested = 0;
      for (auto& pack : {graph_->pack_static, graph_->pack_objects})
        if (pack) {
          kept += pack->kept;
          tested += pack->tested;
        }
      p.kept = tested ? static_cast<double>(kept) / static_cast<double>(tested) : 1.0;
      p.occupied = occupancy_->occupied_fractions();
    }
    double m = exec_->get(graph_->psnr_mse).at(0);
    if (ranks() > 1) reduce_progress(p, m);
    p.psnr = m > 0 ? -10.0 * std::log10(m) : 99.0;
  }
}

// The grids follow the phase: occupancy_estimator.hpp has the schedule.
void Trainer::maybe_update_occupancy(long phase_step) {
  if (occupancy_) occupancy_->maybe_update(*exec_, phase_step, graph_joint_, config_.seed, step_);
}

void Trainer::run(const std::function<void(const TrainProgress&)>& progress, long until_step) {
  const long total = total_steps();
  const long end = until_step < 0 ? total : std::min(until_step, total);
  using clock = std::chrono::steady_clock;
  const auto start = clock::now();
  auto window_start = start;
  long window_steps = 0;
  double pretrain_step_s = 0, joint_step_s = 0;  // recent seconds per step, for the ETA
  write_config();
  std::ofstream metrics;
  if (writes_files()) {
    metrics.open(run_.metrics_path(), std::ios::app);
    if (!metrics) throw Error("cannot write '" + run_.metrics_path() + "'");
  }
  while (step_ < end) {
    const bool log = (step_ + 1) % config_.log_every == 0 || step_ + 1 == end;
    TrainProgress p;
    train_step(log, p);
    ++window_steps;
    if (log) {
      rt_.finish();
      const auto now = clock::now();
      const double window = std::chrono::duration<double>(now - window_start).count();
      const double per_step = window / static_cast<double>(window_steps);
      (p.phase == "joint" ? joint_step_s : pretrain_step_s) = per_step;
      const long pretrain_left = std::max(0L, config_.pretrain_steps - step_);
      const long joint_left = end - step_ - std::min(pretrain_left, end - step_);
      const double joint_estimate = joint_step_s > 0 ? joint_step_s : pretrain_step_s * (1 + geometry_.num_objects);
      p.step = step_;
      p.total = total;
      p.rays_per_s = config_.rays / per_step;
      p.seconds = std::chrono::duration<double>(now - start).count();
      p.eta_seconds = std::min(pretrain_left, end - step_) * pretrain_step_s + joint_left * joint_estimate;
      metrics << detail::metrics_record(p) << "\n";
      metrics.flush();
      if (!std::isfinite(p.loss))
        throw Error("training diverged at step " + std::to_string(p.step) +
                        ": loss is null (try a lower --lr); the last checkpoint is kept",
                    kExitInternal);
      if (progress) progress(p);
      window_start = now;
      window_steps = 0;
    }
    if ((step_ % config_.checkpoint_every == 0 || step_ == end) && writes_files()) write_checkpoint_now();
  }
}

Checkpoint Trainer::checkpoint() {
  ensure_phase();
  Checkpoint ck;
  ck.meta["format"] = kFormat;
  ck.meta["networks"] = network_fingerprint(config_);
  ck.meta["objects"] = std::to_string(scene_.num_objects);
  ck.meta["phase"] = graph_joint_ ? "joint" : "pretrain";
  ck.meta["step"] = std::to_string(step_);
  ck.meta["rng"] = rng_state(rng_);
  ck.meta["adam_steps"] = std::to_string(adam_->steps());
  ck.meta["config"] = format_config(config_);
  for (Tensor p : graph_->graph.parameters())
    ck.arrays.push_back({p.info().name, p.shape().dims, exec_->get(p)});
  const size_t n = adam_->count();
  ck.arrays.push_back({"adam.m", {n}, rt_.download_floats(adam_->first_moment(), n)});
  ck.arrays.push_back({"adam.v", {n}, rt_.download_floats(adam_->second_moment(), n)});
  if (occupancy_) occupancy_->save(ck);
  return ck;
}

void Trainer::bound_objects(const std::vector<float>& boxes) {
  if (occupancy_ && config_.field.object_box && config_.field.object_box_bounded)
    occupancy_->bound_objects(boxes, object_box_margin(config_.field));
}

void Trainer::write_checkpoint_now() { write_checkpoint(run_.checkpoint_path(), checkpoint()); }

void Trainer::resume() {
  const std::string path = run_.checkpoint_path();
  Checkpoint ck = read_checkpoint(path);
  const auto mismatch = [&](const std::string& what) {
    return Error("checkpoint '" + path + "' does not fit this run: " + what);
  };
  if (ck.get("format") != kFormat) throw mismatch("format '" + ck.get("format") + "'");
  run_.check_networks(ck, config_, "this run");
  if (ck.get("objects") != std::to_string(scene_.num_objects))
    throw mismatch(ck.get("objects") + " objects in the checkpoint, " + std::to_string(scene_.num_objects) + " in the scene");
  step_ = std::stol(ck.get("step"));
  if (step_ > total_steps())
    throw mismatch("it is at step " + std::to_string(step_) + ", beyond the configured " + std::to_string(total_steps()));
  // A run trained with no joint steps ends in pretraining at step pretrain-steps, where a
  // longer run is in the joint phase: its checkpoint loads into pretraining, and the next step
  // enters the joint phase as a run that had gone on would have.
  const bool ck_joint = ck.get("phase") == "joint";
  if (ck_joint != joint_phase(step_) && (ck_joint || step_ != config_.pretrain_steps))
    throw mismatch("phase '" + ck.get("phase") + "' at step " + std::to_string(step_) +
                   " (pretrain-steps changed?)");
  exec_.reset();
  ensure_phase(ck_joint);
  for (Tensor p : graph_->graph.parameters()) {
    const CheckpointArray& a = ck.array(p.info().name);
    if (a.shape != p.shape().dims) throw mismatch("parameter '" + a.name + "' has another shape");
    exec_->set(p, a.values);
    if (p.info().name == kObjectBoxName) bound_objects(a.values);
  }
  const CheckpointArray& m = ck.array("adam.m");
  const CheckpointArray& v = ck.array("adam.v");
  if (m.values.size() != adam_->count() || v.values.size() != adam_->count())
    throw mismatch("optimiser state has " + std::to_string(m.values.size()) + " values, expected " +
                   std::to_string(adam_->count()));
  rt_.upload(adam_->first_moment(), m.values.data(), m.values.size() * sizeof(float));
  rt_.upload(adam_->second_moment(), v.values.data(), v.values.size() * sizeof(float));
  adam_->set_steps(std::stol(ck.get("adam_steps")));
  set_rng_state(rng_, ck.get("rng"));
  if (occupancy_) {
    try {
      occupancy_->restore(ck);
    } catch (const Error& e) {
      throw mismatch(e.what());
    }
  }
  if (writes_files()) detail::truncate_metrics(run_.metrics_path(), step_);
  write_config();
}

}  // namespace nova

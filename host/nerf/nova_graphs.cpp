#include "nova/nova_graphs.hpp"

#include <algorithm>
#include <cmath>

#include "nova/error.hpp"
#include "nova/nova_fields.hpp"
#include "nova/ops.hpp"
#include "nova/random.hpp"
#include "nova/rays.hpp"

namespace nova {
namespace {

// Streams of the step graphs' device draws (random.hpp).
constexpr uint32_t kJitterStream = 1, kNoiseStream = 2;

Shape per_group(size_t b, size_t m, size_t c) { return b == 1 ? Shape{m, c} : Shape{b, m, c}; }

SampleOptions sample_options(int samples, const RayGeometry& g, std::vector<int> groups) {
  SampleOptions s;
  s.samples = samples;
  s.near = g.near;
  s.far = g.far;
  s.groups = std::move(groups);
  return s;
}

// The static field on the samples its pack keeps (all of them without one).
Tensor static_raw(Tensor positions, Tensor viewdirs, const FieldConfig& f, std::shared_ptr<PackSelect> pack) {
  if (!pack) return build_static_field(positions, viewdirs, f);
  Packed p = pack_occupied(positions, pack);
  Tensor raw = build_static_field(gather_rows(positions, p), gather_rows(viewdirs, p), f);
  return scatter_rows(raw, p, empty_raw_fill(raw.shape().cols()));
}

Tensor object_raw(Tensor positions, Tensor times, const FieldConfig& f, std::shared_ptr<PackSelect> pack) {
  if (!pack) return build_object_fields(positions, times, f);
  Packed p = pack_occupied(positions, pack);
  Tensor raw = build_object_fields(gather_rows(positions, p), gather_rows(times, p), f);
  return scatter_rows(raw, p, empty_raw_fill(raw.shape().cols()));
}

std::shared_ptr<PackSelect> new_select(bool on, std::vector<int> grid_of_batch) {
  if (!on) return nullptr;
  auto s = std::make_shared<PackSelect>();
  s->grid_of_batch = std::move(grid_of_batch);
  return s;
}

std::vector<int> object_grids(int objects) {
  std::vector<int> v;
  for (int k = 1; k <= objects; ++k) v.push_back(k);
  return v;
}

// 2 / the smallest gap between distinct frame times (frame i of N sits at 2 i / N - 1), so
// a scene with every k-th frame held out still counts N as long as two neighbours remain.
int time_axis_frames(const Scene& scene) {
  if (!scene.has_time) return 0;
  std::vector<double> t;
  for (const Frame& f : scene.frames) t.push_back(f.time);
  std::sort(t.begin(), t.end());
  double gap = 0;
  for (size_t i = 1; i < t.size(); ++i) {
    const double d = t[i] - t[i - 1];
    if (d > 1e-9 && (gap == 0 || d < gap)) gap = d;
  }
  if (gap == 0) return 0;
  return static_cast<int>(std::lround(std::min(2.0 / gap, 1e6)));
}

// Half-sizes along x and y of the NDC box that holds every training ray from the near plane
// (NDC t = 0) to infinity (t = 1). NDC is the reference camera's frustum, so a camera that
// moved sideways sees past x, y = +-1; a box clamped at 1 would give every sample beyond it
// the encoding of the box's face (streaks along x or y in the renders). Rays are straight
// lines in NDC and the image corners span the frustum, so the extremes are at the corners'
// two ends. Each at least 1.
std::array<float, 2> ndc_extent(const Scene& scene) {
  constexpr double kNear = 1.0;  // RayOptions::ndc_near
  double extent[2] = {1.0, 1.0};
  for (const Frame& f : scene.frames) {
    const Camera& c = f.camera;
    const double a[2] = {-c.fx / c.cx, -c.fy / c.cy};
    for (double i : {0.0, c.width - 1.0})
      for (double j : {0.0, c.height - 1.0}) {
        const double u = (i - c.cx) / c.fx, v = -(j - c.cy) / c.fy;
        double d[3], o[3];
        for (int k = 0; k < 3; ++k) {
          d[k] = c.rotation(k, 0) * u + c.rotation(k, 1) * v - c.rotation(k, 2);
          o[k] = c.position(k);
        }
        if (!(d[2] < 0.0)) continue;  // a ray that does not look into the scene
        const double t = -(kNear + o[2]) / d[2];
        for (int k = 0; k < 3; ++k) o[k] += t * d[k];
        for (int k = 0; k < 2; ++k)
          for (double x : {a[k] * o[k] / o[2], a[k] * d[k] / d[2]})
            if (std::isfinite(x)) extent[k] = std::max(extent[k], std::fabs(x));
      }
  }
  return {static_cast<float>(extent[0]), static_cast<float>(extent[1])};
}

}  // namespace

RayGeometry ray_geometry(const Scene& scene) {
  if (scene.frames.empty()) throw Error("scene '" + scene.name + "' has no frames");
  RayGeometry g;
  g.ndc = scene.ndc;
  g.num_objects = scene.num_objects;
  g.disparity = std::all_of(scene.frames.begin(), scene.frames.end(),
                            [](const Frame& f) { return !f.disparity.empty(); });
  g.frames = time_axis_frames(scene);
  if (scene.ndc) {
    const Camera& c = scene.frames.front().camera;
    g.near = 0.0f;
    g.far = 1.0f;
    g.ax = static_cast<float>(-c.fx / c.cx);
    g.ay = static_cast<float>(-c.fy / c.cy);
    const std::array<float, 2> xy = ndc_extent(scene);
    g.box = {xy[0], xy[1], 1.0f};
    g.extent = std::max(xy[0], xy[1]);
  } else {
    if (!(scene.far > scene.near) || scene.near < 0)
      throw Error("scene '" + scene.name + "': bounds [" + std::to_string(scene.near) + ", " +
                  std::to_string(scene.far) + "] are not a valid depth range");
    g.near = static_cast<float>(scene.near);
    g.far = static_cast<float>(scene.far);
    double extent = 0;
    for (const Frame& f : scene.frames)
      for (int r = 0; r < 3; ++r) extent = std::max(extent, std::fabs(f.camera.position(r)));
    g.extent = static_cast<float>(std::max(extent, 1e-3));
    g.box = {g.extent, g.extent, g.extent};
  }
  return g;
}

bool depth_term_active(const TrainConfig& c, const RayGeometry& g) {
  return c.w_depth > 0.0f && disparity_usable(g);
}

bool disparity_usable(const RayGeometry& g) { return g.disparity && g.ndc; }

namespace {

// The per-ray disparity inputs of the depth terms (created once).
void add_depth_inputs(StepGraph& s, const TrainConfig& c) {
  if (s.target_depth.valid()) return;
  const Shape rays{static_cast<size_t>(c.rays)};
  s.target_depth = s.graph.input("target_depth", rays);
  s.depth_valid = s.graph.input("depth_valid", rays);
}

// Adds w_depth * depth_loss(depth, -disparity) to `loss` when the scene supports it.
Tensor with_depth_term(StepGraph& s, const TrainConfig& c, const RayGeometry& geo, Tensor depth,
                       Tensor loss) {
  if (!depth_term_active(c, geo)) return loss;
  add_depth_inputs(s, c);
  Tensor d = depth_loss(depth, s.target_depth, s.depth_valid);
  s.terms.emplace_back("depth", d);
  return weighted_sum({loss, d}, {1.0f, c.w_depth});
}

// Adds w_free_space * free_space_loss of the object NeRFs on their masks' rays (joint
// training, scenes with disparity in NDC).
Tensor with_free_space_term(StepGraph& s, const TrainConfig& c, const RayGeometry& geo,
                            Tensor raw, const Samples& smp, Tensor depth, Tensor loss) {
  if (c.w_free_space <= 0.0f || !disparity_usable(geo)) return loss;
  add_depth_inputs(s, c);
  Tensor f = free_space_loss(raw, smp.delta, smp.z, depth, s.target_depth, s.depth_valid,
                             s.target_masks, s.noise, c.free_space_margin, 1,
                             c.free_space_behind);
  s.terms.emplace_back("free_space", f);
  return weighted_sum({loss, f}, {1.0f, c.w_free_space});
}

// Adds w_distortion * distortion_loss of the object NeRFs (NeRF 0 is the static one), each
// on its mask's rays, to `loss`. On the static NeRF the term cost 2 dB of camera-0 PSNR on
// the default synthetic scene (docs/accuracy.md), so it is not applied there.
Tensor with_distortion_term(StepGraph& s, const TrainConfig& c, Tensor raw, const Samples& smp,
                            Tensor masks, Tensor loss) {
  if (c.w_distortion <= 0.0f) return loss;
  Tensor d = distortion_loss(raw, smp.delta, smp.z, masks, s.noise, 1);
  s.terms.emplace_back("distortion", d);
  return weighted_sum({loss, d}, {1.0f, c.w_distortion});
}

}  // namespace

FieldConfig scene_field(const FieldConfig& f, const RayGeometry& g) {
  FieldConfig out = f;
  if (out.hash.bound <= 0.0f) {
    out.hash.bound = g.ndc ? 1.0f : g.extent;
    if (g.ndc && f.ndc_box_from_rays) out.hash.axis_bound = g.box;
  }
  if (out.occupancy_bound <= 0.0f)
    out.occupancy_bound = out.hash.extend ? std::max(out.hash.max_half_size(), g.extent) : out.hash.max_half_size();
  if (out.hash_time_auto) {
    out.hash.time_max_resolution =
        g.frames > 0 ? std::max(1, static_cast<int>(std::lround(g.frames / kFramesPerTimeCell))) : 0;
    out.hash_time_auto = false;
  }
  return out;
}

// The step's stratified jitter [R, S] and density noise [N, R * S] (N = s.nerfs), drawn on
// the device from the run's seed and the step (StepGraph::draws).
// With a slice, the draws of its rays of the whole step's [R_all, S] and [N, R_all S].
void draw_randomness(StepGraph& s, const TrainConfig& c, size_t R, size_t S, RaySlice slice) {
  s.draws = std::make_shared<DrawCounter>();
  RandomStream jitter{c.seed, kJitterStream, s.draws}, noise{c.seed, kNoiseStream, s.draws};
  if (slice.global_rays) {
    jitter.view_cols = noise.view_cols = R * S;
    jitter.global_cols = noise.global_cols = slice.global_rays * S;
    jitter.col_offset = noise.col_offset = slice.first_ray * S;
  }
  s.jitter = random_uniform(s.graph, "jitter", Shape{R, S}, jitter);
  if (c.noise_std > 0)
    s.noise = random_normal(s.graph, "noise", Shape{static_cast<size_t>(s.nerfs), R * S}, noise, c.noise_std);
}

std::unique_ptr<StepGraph> build_pretrain_graph(const TrainConfig& c, const RayGeometry& geo, RaySlice slice) {
  auto s = std::make_unique<StepGraph>();
  Graph& g = s->graph;
  const size_t R = static_cast<size_t>(c.rays), S = static_cast<size_t>(c.samples);
  s->nerfs = 1;
  s->pixels = g.input("pixels", Shape{R, 2});
  s->cameras = g.input("cameras", Shape{1, kCameraFloats});
  draw_randomness(*s, c, R, S, slice);
  s->target_rgb = g.input("target_rgb", Shape{R, 3});
  Rays rays = generate_rays(s->pixels, s->cameras, {.ndc = geo.ndc});
  Samples smp = stratified_samples(rays, s->jitter, sample_options(c.samples, geo, {1}));
  s->pack_static = new_select(c.occupancy, {0});
  Tensor raw = static_raw(smp.positions[0], smp.viewdirs[0], scene_field(c.field, geo), s->pack_static);
  RenderOutputs out = render_composite(raw, smp.delta, smp.z, s->noise, pretrain_render_options(c.conventions));
  Tensor rgb_loss = pretrain_rgb_loss(out.rgb, s->target_rgb);
  s->psnr_mse = rgb_loss;
  s->terms = {{"static_rgb", rgb_loss}};
  s->loss = with_depth_term(*s, c, geo, out.depth, rgb_loss);
  g.set_loss(s->loss);
  for (auto& [name, t] : s->terms) g.keep(t);
  return s;
}

std::unique_ptr<StepGraph> build_joint_graph(const TrainConfig& c, const RayGeometry& geo, RaySlice slice) {
  const int K = geo.num_objects;
  if (K < 1) throw Error("joint training needs at least one object NeRF", kExitInternal);
  auto s = std::make_unique<StepGraph>();
  Graph& g = s->graph;
  const size_t R = static_cast<size_t>(c.rays), S = static_cast<size_t>(c.samples);
  const size_t N = static_cast<size_t>(1 + K);
  s->nerfs = static_cast<int>(N);
  s->pixels = g.input("pixels", Shape{R, 2});
  s->cameras = g.input("cameras", Shape{N, kCameraFloats});
  draw_randomness(*s, c, R, S, slice);
  s->times = g.input("times", Shape{static_cast<size_t>(K), 1});
  s->target_rgb = g.input("target_rgb", Shape{R, 3});
  s->target_masks = g.input("target_masks", Shape{N, R});
  if (c.conventions.nerf_rgb_area && c.weights.nerf_rgb > 0.0f)
    s->target_nerf_rgb = g.input("target_nerf_rgb", Shape{N, R, 3});
  Rays rays = generate_rays(s->pixels, s->cameras, {.ndc = geo.ndc});
  Samples smp = stratified_samples(rays, s->jitter, sample_options(c.samples, geo, {1, K}));
  const FieldConfig field = scene_field(c.field, geo);
  s->pack_static = new_select(c.occupancy, {0});
  s->pack_objects = new_select(c.occupancy, object_grids(K));
  Tensor raw_static = static_raw(smp.positions[0], smp.viewdirs[0], field, s->pack_static);
  if (c.static_background_only) raw_static = gradient_gate(raw_static, s->target_masks, 0);
  Tensor raw_objects = object_raw(smp.positions[1], repeat_rows(s->times, R * S), field, s->pack_objects);
  Tensor raw = stack({raw_static, raw_objects});
  const RenderOptions ro = joint_render_options(c.conventions, c.weights);
  RenderOutputs out = render_composite(raw, smp.delta, smp.z, s->noise, ro);
  NovelViewLoss l = novel_view_loss(out, raw, smp.delta, s->noise,
                                    {s->target_rgb, s->target_masks, s->target_nerf_rgb}, c.weights,
                                    ro, c.conventions);
  for (auto [name, t] : {std::pair<const char*, Tensor>{"full_rgb", l.full_rgb}, {"nerf_rgb", l.nerf_rgb},
                         {"mask", l.mask}, {"blending", l.blending}, {"alpha", l.alpha},
                         {"sparsity", l.sparsity}, {"order", l.order}})
    if (t.valid()) s->terms.emplace_back(name, t);
  s->loss = with_distortion_term(*s, c, raw, smp, s->target_masks,
                                 with_depth_term(*s, c, geo, out.depth, l.total));
  s->loss = with_free_space_term(*s, c, geo, raw, smp, out.depth, s->loss);
  // The progress PSNR is of the composite colour; without its loss term it is measured
  // separately (a forward-only mse nothing back-propagates through).
  s->psnr_mse = l.full_rgb.valid() ? l.full_rgb : mse(out.rgb, s->target_rgb);
  g.set_loss(s->loss);
  for (auto& [name, t] : s->terms) g.keep(t);
  g.keep(s->psnr_mse);
  return s;
}

std::unique_ptr<ViewGraph> build_view_graph(const FieldConfig& field, int samples,
                                            const RayGeometry& geo, int rays, bool background,
                                            int instances, bool hard_blend, bool packed) {
  const FieldConfig f = scene_field(field, geo);
  if (!background && instances < 1)
    throw Error("a view needs the background or at least one object instance");
  auto v = std::make_unique<ViewGraph>();
  Graph& g = v->graph;
  v->rays = rays;
  v->instances = instances;
  v->background = background;
  const size_t R = static_cast<size_t>(rays), S = static_cast<size_t>(samples);
  const int N = (background ? 1 : 0) + instances;
  // Every NeRF renders along the same camera; one copy per NeRF gives the per-NeRF spacing
  // tensor render_composite takes. Only the first group's positions are read.
  v->pixels = g.input("pixels", Shape{R, 2});
  v->cameras = g.input("cameras", Shape{static_cast<size_t>(N), kCameraFloats});
  Rays r = generate_rays(v->pixels, v->cameras, {.ndc = geo.ndc});
  Samples smp = stratified_samples(r, Tensor{}, sample_options(samples, geo, N == 1 ? std::vector<int>{1}
                                                                                  : std::vector<int>{1, N - 1}));
  std::vector<Tensor> parts;
  if (background) {
    v->pack_static = new_select(packed, {0});
    parts.push_back(static_raw(smp.positions[0], smp.viewdirs[0], f, v->pack_static));
  }
  if (instances > 0) {
    const size_t B = static_cast<size_t>(instances);
    v->transforms = g.input("transforms", Shape{B, 12});
    v->times = g.input("times", Shape{B, 1});
    InstanceOptions io;
    io.ndc = geo.ndc;
    io.ax = geo.ax;
    io.ay = geo.ay;
    Tensor pos = instance_points(smp.positions[0], v->transforms, io);
    v->pack_objects = new_select(packed, std::vector<int>(B, 1));
    parts.push_back(object_raw(pos, repeat_rows(v->times, R * S), f, v->pack_objects));
  }
  Tensor raw = parts.size() == 1 ? parts[0] : stack(parts);
  RenderOptions ro;
  ro.hard_blend = hard_blend && background && instances > 0;
  v->out = render_composite(raw, smp.delta, smp.z, Tensor{}, ro);
  for (Tensor t : {v->out.rgb, v->out.mask, v->out.depth, v->out.acc}) g.keep(t);
  return v;
}

std::unique_ptr<DensityGraph> build_density_graph(const FieldConfig& field, const RayGeometry& geo, int objects,
                                                  int points) {
  const FieldConfig f = scene_field(field, geo);
  auto d = std::make_unique<DensityGraph>();
  Graph& g = d->graph;
  const size_t P = static_cast<size_t>(points);
  d->static_positions = g.input("positions", Shape{P, 3});
  d->static_viewdirs = g.input("viewdirs", Shape{P, 3});
  d->static_raw = build_static_field(d->static_positions, d->static_viewdirs, f);
  g.keep(d->static_raw);
  if (objects > 0) {
    const size_t K = static_cast<size_t>(objects);
    d->object_positions = g.input("object_positions", per_group(K, P, 3));
    d->object_times = g.input("object_times", per_group(K, P, 1));
    d->object_raw = build_object_fields(d->object_positions, d->object_times, f);
    g.keep(d->object_raw);
  }
  return d;
}

}  // namespace nova

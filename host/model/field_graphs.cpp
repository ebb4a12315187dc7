#include "nova/model/field_graphs.hpp"

#include <algorithm>
#include <cmath>

#include "nova/sampling/camera.hpp"
#include "nova/runtime/error.hpp"
#include "nova/sampling/rigid_motion.hpp"
#include "nova/model/fields.hpp"
#include "nova/ops/tensor/tensor_ops.hpp"
#include "nova/sampling/rays.hpp"
#include "nova/sampling/sample_warp.hpp"

namespace nova {
namespace {

Shape per_group(size_t b, size_t m, size_t c) { return b == 1 ? Shape{m, c} : Shape{b, m, c}; }

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
        const std::array<double, 3> d = camera_ray_direction(c, i, j);
        double o[3] = {c.position(0), c.position(1), c.position(2)};
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

SampleOptions sample_options(int samples, const RayGeometry& g, std::vector<int> groups) {
  SampleOptions s;
  s.samples = samples;
  s.near = g.near;
  s.far = g.far;
  s.groups = std::move(groups);
  return s;
}

Tensor static_raw(Tensor positions, Tensor viewdirs, const FieldConfig& f, std::shared_ptr<PackSelect> pack) {
  if (!pack) return build_static_field(positions, viewdirs, f);
  Packed p = pack_occupied(positions, pack);
  Tensor raw = build_static_field(gather_rows(positions, p), gather_rows(viewdirs, p), f);
  return scatter_rows(raw, p, empty_raw_fill(raw.shape().cols()));
}

MotionOptions motion_options(const RayGeometry& g) {
  MotionOptions o;
  o.frames = std::max(1, g.frames);
  o.ndc = g.ndc;
  o.ax = g.ax;
  o.ay = g.ay;
  o.ndc_near = 1.0f;  // RayOptions::ndc_near
  return o;
}

Tensor object_raw(Tensor positions, Tensor times, const FieldConfig& f, const RayGeometry& g,
                  std::shared_ptr<PackSelect> pack, Tensor motion, Tensor level_window) {
  const Shape& ps = positions.shape();
  // The objects' times spread over their rows (a canonical field does not read them: a
  // placeholder of the right shape).
  Tensor row_times = repeat_rows(times, ps.rank() == 3 ? ps[1] : ps[0]);
  // Samples into the field's coordinates: moved into each object's canonical space when it
  // has a learned motion here. Packing tests those coordinates (a forward only: the decision
  // has no gradient); the kept rows are moved again, and the gradient reaches the motion
  // through them.
  const bool moved = f.motion == ObjectMotion::Rigid && motion.valid();
  const MotionOptions mo = motion_options(g);
  const auto place = [&](Tensor p, bool differentiable) {
    return moved ? rigid_motion(p, times, motion, mo, differentiable) : p;
  };
  if (!pack) return build_object_fields(place(positions, true), row_times, f, level_window);
  Packed p = pack_occupied(place(positions, false), pack);
  Tensor raw = build_object_fields(place(gather_rows(positions, p), true), gather_rows(row_times, p), f, level_window);
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

std::unique_ptr<ViewGraph> build_view_graph(const FieldConfig& field, int samples,
                                            const RayGeometry& geo, int rays, bool background,
                                            int instances, bool hard_blend, bool packed, bool warped) {
  const FieldConfig f = scene_field(field, geo);
  if (!background && instances < 1)
    throw Error("a view needs the background or at least one object instance");
  auto v = std::make_unique<ViewGraph>();
  Graph& g = v->graph;
  v->rays = rays;
  v->instances = instances;
  v->background = background;
  const size_t R = static_cast<size_t>(rays);
  const int N = (background ? 1 : 0) + instances;
  // Every NeRF renders along the same camera; one copy per NeRF gives the per-NeRF spacing
  // tensor render_composite takes. Only the first group's positions are read.
  v->pixels = g.input("pixels", Shape{R, 2});
  v->cameras = g.input("cameras", Shape{static_cast<size_t>(N), kCameraFloats});
  Rays r = generate_rays(v->pixels, v->cameras, {.ndc = geo.ndc});
  if (warped && instances > 0) v->warp = g.input("warp", Shape{sample_warp_knots(static_cast<size_t>(instances)), 2});
  Samples smp = stratified_samples(r, Tensor{}, sample_options(samples, geo, N == 1 ? std::vector<int>{1}
                                                                                  : std::vector<int>{1, N - 1}),
                                   v->warp);
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
    // A rigid object's learned motion at the instance's time is composed into its transform
    // by the renderer (motion_matrix): the field sees canonical positions either way.
    Tensor pos = instance_points(smp.positions[0], v->transforms, io);
    v->pack_objects = new_select(packed, std::vector<int>(B, 1));
    parts.push_back(object_raw(pos, v->times, f, geo, v->pack_objects));
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

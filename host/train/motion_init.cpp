// The starting trajectory of each rigid object (motion.hpp). The disparity is placed in depth
// by the static background's parallax (disparity_fit.hpp); each frame's object pixels are then
// points in the scene, and the object's motion from one frame to the next is found by aligning
// them (motion_alignment.hpp): the first frame that shows the object fixes its canonical
// space (its mask's centroid at its median depth, unturned), and every later frame is the
// previous one moved by the alignment. Without a usable disparity (none, or a video without
// parallax) the objects do not turn: each frame's anchor is the mask's centroid in front of
// what the static NeRF shows behind it.
#include "nova/train/motion_init.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include "nova/sampling/camera.hpp"
#include "nova/train/disparity_fit.hpp"
#include "nova/runtime/error.hpp"
#include "nova/graph/executor.hpp"
#include "nova/train/motion_alignment.hpp"
#include "nova/model/field_graphs.hpp"
#include "nova/sampling/rays.hpp"
#include "nova/train/step_graphs.hpp"
#include "train/parallel_for.hpp"

namespace nova {
namespace {

constexpr int kFitRays = 1024;       // rays of one render of the static NeRF's depth
constexpr int kFitPixelsPerFrame = 768;

struct Pixel {
  int x, y;
};

// Up to `count` pixels of `frame` on a regular grid for which `keep` holds.
template <class Keep>
std::vector<Pixel> grid_pixels(const Frame& f, int count, Keep keep) {
  const int W = f.rgb.width, H = f.rgb.height;
  const int stride = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(W) * H / std::max(count, 1))));
  std::vector<Pixel> out;
  for (int y = stride / 2; y < H; y += stride)
    for (int x = stride / 2; x < W; x += stride)
      if (keep(x, y)) out.push_back({x, y});
  return out;
}

// The static NeRF's rendered depth (NDC t or metric) at `pixels` of `camera`.
std::vector<float> static_depth(Executor& ex, ViewGraph& vg, const Camera& camera, const std::vector<Pixel>& pixels) {
  std::vector<float> depth;
  ex.set(vg.cameras, camera_rows({camera}));
  const size_t R = static_cast<size_t>(vg.rays);
  for (size_t first = 0; first < pixels.size(); first += R) {
    std::vector<float> px(R * 2);
    const size_t n = std::min(R, pixels.size() - first);
    for (size_t i = 0; i < R; ++i) {
      const Pixel& p = pixels[first + std::min(i, n - 1)];
      px[i * 2] = static_cast<float>(p.x);
      px[i * 2 + 1] = static_cast<float>(p.y);
    }
    ex.set(vg.pixels, px);
    ex.forward();
    const std::vector<float> d = ex.get(vg.out.depth);
    depth.insert(depth.end(), d.begin(), d.begin() + static_cast<long>(n));
  }
  return depth;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// The world point of pixel (x, y) of `camera` at rendered depth `t` (NDC t in [0, 1): world
// depth 1 / (1 - t) in front of the near plane z = -1, RayOptions; metric: the ray's length).
Vec3 world_point(const Camera& c, double x, double y, double t, bool ndc) {
  const Vec3 d = camera_ray_direction(c, x, y);
  double s = t;
  if (ndc) {
    const double z = -1.0 / std::max(1.0 - std::clamp(t, 0.0, 0.999), 1e-3);
    s = std::fabs(d[2]) > 1e-9 ? (z - c.position(2)) / d[2] : 1.0;
  } else {
    s = t / std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  }
  return camera_unproject(c, x, y, s);
}

// Camera-space depth of every pixel of `f` from its disparity placed by `fit` (0: unknown).
ImageF fitted_depth(const Frame& f, const DisparityFit& fit) {
  ImageF out;
  out.width = f.disparity.width;
  out.height = f.disparity.height;
  out.data.assign(f.disparity.data.size(), 0.0f);
  for (size_t i = 0; i < out.data.size(); ++i) {
    const double w = fit.inverse_depth(f.disparity.data[i]);
    if (w > 0 && std::isfinite(w)) out.data[i] = static_cast<float>(1.0 / w);
  }
  return out;
}

}  // namespace

std::array<float, 6> object_box_row(const Vec3& centre, double half, const RayGeometry& geo) {
  // NDC (RayOptions::ndc_near 1): ndc(x) = (ax x / z, ay y / z, 1 + 2 / z) for z < 0.
  const auto map = [&](Vec3 x) -> Vec3 {
    if (!geo.ndc) return x;
    const double z = std::min(x[2], -1e-3);
    return {geo.ax * x[0] / z, geo.ay * x[1] / z, 1.0 + 2.0 / z};
  };
  const Vec3 c = map(centre);
  // NDC is linear-fractional, so the cube's image lies between the images of its corners.
  std::array<double, 3> h{};
  for (int i = 0; i < 8; ++i) {
    const Vec3 corner = map({centre[0] + (i & 1 ? half : -half), centre[1] + (i & 2 ? half : -half),
                             centre[2] + (i & 4 ? half : -half)});
    for (size_t d = 0; d < 3; ++d) h[d] = std::max(h[d], std::fabs(corner[d] - c[d]));
  }
  std::array<float, 6> row{};
  for (size_t d = 0; d < 3; ++d) {
    // Never coarser than the scene's own box: an object as large as the scene keeps its grid.
    const double scene_half = geo.ndc ? geo.box[d] : geo.extent;
    row[d] = static_cast<float>(c[d]);
    row[3 + d] = static_cast<float>(-std::log(std::clamp(h[d], 1e-6, static_cast<double>(scene_half))));
  }
  return row;
}

std::array<float, 6> object_box_for(const float* rows, int frames, double radius, const RayGeometry& geo) {
  return object_box_row(motion_pivot(rows, frames), kObjectBoxRadii * radius, geo);
}

double mask_radius(const Image8& mask, const Camera& camera, const Vec3& anchor) {
  double cx = 0, cy = 0, n = 0;
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x)
      if (mask.at(x, y) >= 128) cx += x, cy += y, n += 1;
  if (n == 0) return 0;
  cx /= n;
  cy /= n;
  std::vector<double> spread;
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x)
      if (mask.at(x, y) >= 128) spread.push_back(std::hypot(x - cx, y - cy));
  std::nth_element(spread.begin(), spread.begin() + static_cast<long>(spread.size() * 95 / 100), spread.end());
  const double pixels = spread[spread.size() * 95 / 100] + 0.5;
  double distance = 0;
  for (int d = 0; d < 3; ++d) distance += (anchor[d] - camera.position(d)) * (anchor[d] - camera.position(d));
  return pixels * std::sqrt(distance) / camera.fx;
}

std::vector<size_t> outlier_anchors(const std::vector<Vec3>& anchors, const std::vector<int>& frames, double floor) {
  if (frames.size() != anchors.size()) throw Error("outlier_anchors: one frame per anchor", kExitInternal);
  std::vector<size_t> kept(anchors.size()), dropped;
  for (size_t j = 0; j < kept.size(); ++j) kept[j] = j;
  const auto distance = [&](const Vec3& a, const Vec3& b) {
    return std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
  };
  // Each pass drops the anchor farthest from where its kept neighbours put it, while that is
  // more than kOutlierSteps typical steps and more than `floor`.
  while (kept.size() >= 4) {
    std::vector<double> steps;
    for (size_t j = 1; j < kept.size(); ++j) steps.push_back(distance(anchors[kept[j]], anchors[kept[j - 1]]));
    const double typical = median(steps);
    size_t worst = 0;
    double worst_residual = -1;
    for (size_t j = 0; j < kept.size(); ++j) {
      // Between its neighbours where it has two (linear), else beyond the nearest two.
      const size_t a = j == 0 ? 1 : j - 1, b = j == 0 ? 2 : (j + 1 < kept.size() ? j + 1 : j - 2);
      const double ia = frames[kept[a]], ib = frames[kept[b]], w = (frames[kept[j]] - ia) / (ib - ia);
      Vec3 predicted;
      for (int d = 0; d < 3; ++d) predicted[d] = (1 - w) * anchors[kept[a]][d] + w * anchors[kept[b]][d];
      const double residual = distance(anchors[kept[j]], predicted);
      if (residual > worst_residual) worst_residual = residual, worst = j;
    }
    if (worst_residual <= std::max(kOutlierSteps * typical, floor)) break;
    dropped.push_back(kept[worst]);
    kept.erase(kept.begin() + static_cast<long>(worst));
  }
  std::sort(dropped.begin(), dropped.end());
  return dropped;
}

std::vector<size_t> off_path_anchors(const std::vector<Vec3>& anchors, const std::vector<int>& frames,
                                     const std::vector<double>& radii) {
  if (radii.size() != anchors.size()) throw Error("off_path_anchors: one radius per anchor", kExitInternal);
  return outlier_anchors(anchors, frames, kOutlierRadii * median(radii));
}

std::vector<MotionRow> fill_motion_rows(const std::vector<int>& known, const std::vector<MotionRow>& rows, int frames) {
  if (known.empty() || known.size() != rows.size())
    throw Error("fill_motion_rows: " + std::to_string(known.size()) + " known frames for " + std::to_string(rows.size()) +
                    " rows",
                kExitInternal);
  std::vector<MotionRow> out(static_cast<size_t>(frames));
  const size_t last = known.size() - 1;
  for (int i = 0; i < frames; ++i) {
    MotionRow& p = out[static_cast<size_t>(i)];
    const auto after = std::lower_bound(known.begin(), known.end(), i);
    if (after == known.begin() || after == known.end()) {
      // Beyond the frames that show it the object keeps the speed of the nearest two, its turn
      // held: it walks out of view as it came in, where holding its place would draw it into
      // frames whose masks say it is not there, against its own canonical shape.
      const bool before = after == known.begin();
      const size_t a = before ? 0 : last, b = before ? std::min<size_t>(1, last) : (last > 0 ? last - 1 : 0);
      p = rows[a];
      if (a == b) continue;
      const double steps = static_cast<double>(i - known[a]) / (known[a] - known[b]);
      for (size_t d = 3; d < 6; ++d) p[d] += steps * (rows[a][d] - rows[b][d]);
    } else {
      const size_t hi = static_cast<size_t>(after - known.begin()), lo = hi - 1;
      const double w = known[hi] == i ? 1.0 : static_cast<double>(i - known[lo]) / (known[hi] - known[lo]);
      for (size_t d = 0; d < 6; ++d) p[d] = (1 - w) * rows[lo][d] + w * rows[hi][d];
    }
  }
  return out;
}

MotionStart initial_motion(Runtime& rt, const Scene& scene, const RayGeometry& geo, const FieldConfig& field,
                           int samples, Executor& trained, const DisparityFit* known_fit,
                           const AlignmentOptions& align) {
  const int K = geo.num_objects, F = motion_options(geo).frames;
  if (K < 1) throw Error("initial_motion: the scene has no objects", kExitInternal);
  const DisparityFit fit = !geo.disparity ? DisparityFit{} : known_fit ? *known_fit : fit_disparity(scene);
  const bool fitted = fit.ok;
  // Without a fit: the static NeRF's depth behind the objects' masks.
  std::vector<std::vector<Pixel>> inside(scene.frames.size());
  std::vector<std::vector<float>> behind(scene.frames.size());
  std::unique_ptr<ViewGraph> vg;
  std::unique_ptr<Executor> ex;
  if (!fitted) {
    vg = build_view_graph(field, samples, geo, kFitRays, true, 0, false, false);
    ex = std::make_unique<Executor>(rt, vg->graph);
    copy_parameters(*ex, trained, kStaticPrefix);
  }
  for (size_t i = 0; i < scene.frames.size() && !fitted; ++i) {
    const Frame& f = scene.frames[i];
    inside[i] = grid_pixels(f, kFitPixelsPerFrame, [&](int x, int y) {
      for (int k = 1; k <= K; ++k)
        if (f.masks.at(static_cast<size_t>(k)).at(x, y) >= 128) return true;
      return false;
    });
    behind[i] = static_depth(*ex, *vg, f.camera, inside[i]);
  }

  // Per frame the camera-space depth of every pixel, from the fitted disparity: what the
  // alignment of an object between frames places its pixels by.
  std::vector<ImageF> depth(fitted ? scene.frames.size() : 0);
  for (size_t i = 0; i < depth.size(); ++i) depth[i] = fitted_depth(scene.frames[i], fit);

  // Per object, the anchor of every frame that shows it; frames without one take their
  // neighbours' (linear between, the nearest beyond).
  std::vector<float> rows(static_cast<size_t>(K) * F * 6, 0.0f), boxes(static_cast<size_t>(K) * 6, 0.0f);
  std::vector<float> object_radii(static_cast<size_t>(K), 0.0f);
  // The objects are independent: one track each, on the host's cores.
  detail::parallel_for(static_cast<size_t>(K), [&](size_t object) {
    const int k = static_cast<int>(object) + 1;
    double radius = 0;  // world units, the largest over the frames
    std::vector<std::optional<Vec3>> anchor(static_cast<size_t>(F));
    std::vector<size_t> frame_of(static_cast<size_t>(F));
    std::vector<double> radius_of(static_cast<size_t>(F), 0.0);  // world units, per frame
    for (size_t i = 0; i < scene.frames.size(); ++i) {
      const Frame& f = scene.frames[i];
      const Image8& m = f.masks.at(static_cast<size_t>(k));
      double cx = 0, cy = 0, n = 0;
      std::vector<double> disp;
      for (int y = 0; y < m.height; ++y)
        for (int x = 0; x < m.width; ++x)
          if (m.at(x, y) >= 128) {
            cx += x;
            cy += y;
            n += 1;
            if (fitted) disp.push_back(f.disparity.data[static_cast<size_t>(y) * f.disparity.width + x]);
          }
      if (n == 0) continue;
      cx /= n;
      cy /= n;
      const int index = std::clamp(static_cast<int>(std::lround((f.time + 1.0) * 0.5 * F)), 0, F - 1);
      frame_of[static_cast<size_t>(index)] = i;
      if (fitted) {
        const double w = fit.inverse_depth(median(disp));
        if (w > 0) anchor[static_cast<size_t>(index)] = camera_unproject(f.camera, cx, cy, 1.0 / w);
      } else {
        std::vector<double> d;
        for (size_t j = 0; j < inside[i].size(); ++j)
          if (m.at(inside[i][j].x, inside[i][j].y) >= 128) d.push_back(behind[i][j]);
        // In front of what the static NeRF shows behind it: its nearer quartile.
        std::sort(d.begin(), d.end());
        const double t = std::clamp(d.empty() ? 0.5 * (geo.near + geo.far) : d[d.size() / 4],
                                    static_cast<double>(geo.near), static_cast<double>(geo.far));
        anchor[static_cast<size_t>(index)] = world_point(f.camera, cx, cy, t, geo.ndc);
      }
      if (const auto& a = anchor[static_cast<size_t>(index)]) radius_of[static_cast<size_t>(index)] = mask_radius(m, f.camera, *a);
    }
    std::vector<int> known;
    for (int i = 0; i < F; ++i)
      if (anchor[static_cast<size_t>(i)]) known.push_back(i);
    if (known.empty()) return;  // never seen: it stays at the origin
    // A mask that took in a piece of the background (a made mask where the object touches
    // something static) puts its median depth, and with it the anchor, far off the object's
    // path for that frame: such frames take their neighbours' rows, and neither the
    // alignment nor the box reads them. A jump within the object's own size is not one.
    {
      std::vector<Vec3> path;
      std::vector<double> radii;
      for (int i : known) {
        path.push_back(*anchor[static_cast<size_t>(i)]);
        radii.push_back(radius_of[static_cast<size_t>(i)]);
      }
      const std::vector<size_t> dropped = off_path_anchors(path, known, radii);
      for (auto j = dropped.rbegin(); j != dropped.rend(); ++j) {
        anchor[static_cast<size_t>(known[*j])].reset();
        known.erase(known.begin() + static_cast<long>(*j));
      }
    }
    for (int i : known) radius = std::max(radius, radius_of[static_cast<size_t>(i)]);

    // The object's pose (object -> world) at every frame that shows it: the first at its
    // anchor, unturned; each next one the previous moved by the alignment of the two frames
    // (without depth to place the pixels by, no turn: anchor to anchor).
    std::vector<Mat34> poses;
    if (fitted) {
      std::vector<ObjectView> views;
      std::vector<Vec3> anchors;
      for (int i : known) {
        const size_t f = frame_of[static_cast<size_t>(i)];
        const Frame& frame = scene.frames[f];
        views.push_back({&frame.camera, &frame.rgb, &frame.masks.at(static_cast<size_t>(k)), &depth[f]});
        anchors.push_back(*anchor[static_cast<size_t>(i)]);
      }
      poses = track_object(views, anchors, align);
    } else {
      for (int i : known) {
        Mat34 pose{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
        for (int d = 0; d < 3; ++d) pose[static_cast<size_t>(d * 4 + 3)] = (*anchor[static_cast<size_t>(i)])[d];
        poses.push_back(pose);
      }
    }
    std::vector<MotionRow> known_rows;
    Vec3 angles{0, 0, 0};
    for (const Mat34& pose : poses) {
      // y = R (x - tau) + q with R the pose's rotation transposed and tau its translation.
      const Mat3 R{pose[0], pose[4], pose[8], pose[1], pose[5], pose[9], pose[2], pose[6], pose[10]};
      angles = matrix_to_euler_xyz(R, angles);
      known_rows.push_back({angles[0], angles[1], angles[2], pose[3], pose[7], pose[11]});
    }
    float* r = rows.data() + static_cast<size_t>(k - 1) * F * 6;
    const std::vector<MotionRow> all = fill_motion_rows(known, known_rows, F);
    for (int i = 0; i < F; ++i)
      for (int d = 0; d < 6; ++d) r[static_cast<size_t>(i) * 6 + d] = static_cast<float>(all[static_cast<size_t>(i)][static_cast<size_t>(d)]);
    const std::array<float, 6> box = object_box_for(r, F, radius, geo);
    std::copy(box.begin(), box.end(), boxes.begin() + static_cast<long>(k - 1) * 6);
    object_radii[static_cast<size_t>(k - 1)] = static_cast<float>(radius);
  });
  return {rows, boxes, object_radii};
}

}  // namespace nova

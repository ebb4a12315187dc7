// The starting trajectory of each rigid object (motion.hpp): per frame, its mask's centroid
// placed at the object's depth along that frame's camera ray. The depth comes from the
// disparity, placed in the rendered depth's units by a least-squares fit to the pretrained
// static NeRF's depth on background pixels (the only depth that is known to be right, up to
// the fit); without disparity, from the static NeRF's depth behind the mask (the object stands
// in front of it). The same fallback serves a disparity that does not fit (wrong sign).
#include "nova/motion_init.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include "nova/error.hpp"
#include "nova/executor.hpp"
#include "nova/nova_graphs.hpp"
#include "nova/rays.hpp"
#include "nova/step_graphs.hpp"

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
  const double u = (x - c.cx) / c.fx, v = -(y - c.cy) / c.fy;
  Vec3 d{}, o{};
  for (int k = 0; k < 3; ++k) {
    d[k] = c.rotation(k, 0) * u + c.rotation(k, 1) * v - c.rotation(k, 2);
    o[k] = c.position(k);
  }
  double s = t;
  if (ndc) {
    const double z = -1.0 / std::max(1.0 - std::clamp(t, 0.0, 0.999), 1e-3);
    s = std::fabs(d[2]) > 1e-9 ? (z - o[2]) / d[2] : 1.0;
  } else {
    const double norm = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    s = t / norm;
  }
  return {o[0] + s * d[0], o[1] + s * d[1], o[2] + s * d[2]};
}

}  // namespace

std::vector<float> initial_motion(Runtime& rt, const Scene& scene, const RayGeometry& geo, const FieldConfig& field,
                                  int samples, Executor& trained) {
  const int K = geo.num_objects, F = motion_options(geo).frames;
  if (K < 1) throw Error("initial_motion: the scene has no objects", kExitInternal);
  std::unique_ptr<ViewGraph> vg = build_view_graph(field, samples, geo, kFitRays, true, 0, false, false);
  Executor ex(rt, vg->graph);
  copy_parameters(ex, trained, kStaticPrefix);

  // The static NeRF's depth against the disparity on background pixels: depth = a + b disp.
  const bool disparity = disparity_usable(geo);
  double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (const Frame& f : scene.frames) {
    if (!disparity) break;
    const Image8& bg = f.masks.at(0);
    const std::vector<Pixel> px = grid_pixels(f, kFitPixelsPerFrame, [&](int x, int y) { return bg.at(x, y) >= 128; });
    const std::vector<float> d = static_depth(ex, *vg, f.camera, px);
    for (size_t j = 0; j < px.size(); ++j) {
      const double x = f.disparity.data[static_cast<size_t>(px[j].y) * f.disparity.width + px[j].x], y = d[j];
      if (!std::isfinite(x) || !std::isfinite(y)) continue;
      sw += 1;
      sx += x;
      sy += y;
      sxx += x * x;
      sxy += x * y;
    }
  }
  double a = 0, b = 0;
  bool fitted = false;
  if (sw > 2) {
    const double var = sxx - sx * sx / sw;
    if (var > 0) {
      b = (sxy - sx * sy / sw) / var;
      a = (sy - b * sx) / sw;
      // Nearer is larger disparity and smaller depth: a fit that says otherwise is no fit.
      fitted = b < 0;
    }
  }
  // Without a fit: the static NeRF's depth behind the objects' masks.
  std::vector<std::vector<Pixel>> inside(scene.frames.size());
  std::vector<std::vector<float>> behind(scene.frames.size());
  for (size_t i = 0; i < scene.frames.size() && !fitted; ++i) {
    const Frame& f = scene.frames[i];
    inside[i] = grid_pixels(f, kFitPixelsPerFrame, [&](int x, int y) {
      for (int k = 1; k <= K; ++k)
        if (f.masks.at(static_cast<size_t>(k)).at(x, y) >= 128) return true;
      return false;
    });
    behind[i] = static_depth(ex, *vg, f.camera, inside[i]);
  }

  // Per object, the anchor of every frame that shows it; frames without one take their
  // neighbours' (linear between, the nearest beyond).
  std::vector<float> rows(static_cast<size_t>(K) * F * 6, 0.0f);
  for (int k = 1; k <= K; ++k) {
    std::vector<std::optional<Vec3>> anchor(static_cast<size_t>(F));
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
      double t;
      if (fitted) {
        t = a + b * median(disp);
      } else {
        std::vector<double> d;
        for (size_t j = 0; j < inside[i].size(); ++j)
          if (m.at(inside[i][j].x, inside[i][j].y) >= 128) d.push_back(behind[i][j]);
        // In front of what the static NeRF shows behind it: its nearer quartile.
        std::sort(d.begin(), d.end());
        t = d.empty() ? 0.5 * (geo.near + geo.far) : d[d.size() / 4];
      }
      t = std::clamp(t, static_cast<double>(geo.near), static_cast<double>(geo.far));
      const int index = std::clamp(static_cast<int>(std::lround((f.time + 1.0) * 0.5 * F)), 0, F - 1);
      anchor[static_cast<size_t>(index)] = world_point(f.camera, cx, cy, t, geo.ndc);
    }
    std::vector<int> known;
    for (int i = 0; i < F; ++i)
      if (anchor[static_cast<size_t>(i)]) known.push_back(i);
    if (known.empty()) continue;  // never seen: it stays at the origin
    float* r = rows.data() + static_cast<size_t>(k - 1) * F * 6;
    for (int i = 0; i < F; ++i) {
      const auto after = std::lower_bound(known.begin(), known.end(), i);
      Vec3 p;
      if (after == known.begin()) p = *anchor[static_cast<size_t>(known.front())];
      else if (after == known.end()) p = *anchor[static_cast<size_t>(known.back())];
      else {
        const int hi = *after, lo = *(after - 1);
        const double w = hi == lo ? 0.0 : static_cast<double>(i - lo) / (hi - lo);
        for (int d = 0; d < 3; ++d)
          p[d] = (1 - w) * (*anchor[static_cast<size_t>(lo)])[d] + w * (*anchor[static_cast<size_t>(hi)])[d];
      }
      for (int d = 0; d < 3; ++d) r[static_cast<size_t>(i) * 6 + 3 + d] = static_cast<float>(p[d]);
    }
  }
  return rows;
}

}  // namespace nova

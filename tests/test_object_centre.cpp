// The centre an instance without pivot= turns about (object_centre.hpp): density_centroid
// against a float64 host reference of the same rule, and against the analytic centres of
// densities whose centre is known (balls and Gaussian blobs, centred, off-centre and
// asymmetric), in a metric field and in an NDC field.
#include <boost/test/unit_test.hpp>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <vector>

#include "harness.hpp"
#include "nova/data/scene_io.hpp"
#include "nova/model/fields.hpp"
#include "nova/model/field_graphs.hpp"
#include "nova/model/object_centre.hpp"
#include "nova/train/train_config.hpp"
#include "nova/model/view_renderer.hpp"
#include "scene_test_util.hpp"

using namespace nova;
using nova::test::runtime;

namespace {

using Vec3 = std::array<double, 3>;
using Density = std::function<double(const Vec3&)>;  // world point -> world density

// The float64 reference of object_centre.hpp's rule, written out independently: cell centres,
// the threshold (alpha = 1 - exp(-sigma cell) > alpha, or sigma over max_fraction of the
// peak; nothing below floor_alpha), the density-weighted mean in field coordinates, and the
// NDC -> world map of that mean.
struct Ref {
  bool found = false;
  Vec3 centre{};
  size_t cells = 0;
};
Ref reference_centroid(const std::vector<float>& density, int G, double bound, const CentroidOptions& o) {
  const double cell = 2 * bound / G;
  Ref r;
  double peak = 0;
  for (float v : density)
    if (v > 0 && std::isfinite(v)) peak = std::max<double>(peak, v);
  if (1 - std::exp(-peak * cell) <= o.floor_alpha) return r;
  double W = 0, S[3] = {0, 0, 0};
  for (int k = 0; k < G; ++k)
    for (int j = 0; j < G; ++j)
      for (int i = 0; i < G; ++i) {
        const double sigma = density[(static_cast<size_t>(k) * G + j) * G + i];
        if (!(sigma > 0) || (1 - std::exp(-sigma * cell) <= o.alpha && sigma <= o.max_fraction * peak)) continue;
        const double p[3] = {-bound + (i + 0.5) * cell, -bound + (j + 0.5) * cell, -bound + (k + 0.5) * cell};
        W += sigma;
        for (int d = 0; d < 3; ++d) S[d] += sigma * p[d];
        ++r.cells;
      }
  if (r.cells == 0) return r;
  r.found = true;
  double m[3];
  for (int d = 0; d < 3; ++d) m[d] = S[d] / W;
  if (o.ndc) {  // the mean, in NDC, into the world
    const double z = 2 * o.ndc_near / (m[2] - 1);
    r.centre = {m[0] * z / o.ax, m[1] * z / o.ay, z};
  } else {
    r.centre = {m[0], m[1], m[2]};
  }
  return r;
}

// The grid a probe would fill: the field density at each cell centre (float, as the device
// returns it). In NDC the field density of a world density sigma_w at depth z is
// sigma_w z^2 / (2 n) (a world length dl along z is 2 n / z^2 dl NDC long).
std::vector<float> sample_field(const Density& world_density, int G, double bound, const CentroidOptions& o) {
  std::vector<float> d(static_cast<size_t>(G) * G * G);
  for (size_t c = 0; c < d.size(); ++c) {
    const Vec3 w = field_to_world(probe_cell_centre(c, G, bound), o);
    const double s = world_density(w);
    d[c] = static_cast<float>(o.ndc ? s * w[2] * w[2] / (2 * o.ndc_near) : s);
  }
  return d;
}

Density ball(const Vec3& c, double radius, double sigma) {
  return [=](const Vec3& p) {
    double r2 = 0;
    for (int d = 0; d < 3; ++d) r2 += (p[d] - c[d]) * (p[d] - c[d]);
    return r2 <= radius * radius ? sigma : 0.0;
  };
}

Density gaussian(const Vec3& c, const Vec3& sd, double peak) {
  return [=](const Vec3& p) {
    double e = 0;
    for (int d = 0; d < 3; ++d) e += (p[d] - c[d]) * (p[d] - c[d]) / (sd[d] * sd[d]);
    return peak * std::exp(-0.5 * e);
  };
}

double max_abs(const Vec3& a, const Vec3& b) {
  double m = 0;
  for (int d = 0; d < 3; ++d) m = std::max(m, std::fabs(a[d] - b[d]));
  return m;
}

// density_centroid against the reference on the same float densities: both sum the same
// terms in double, in another order and with another formulation of the threshold (log1p
// against exp), so they agree to double rounding over a few thousand terms: 1e-9 of the box.
void check_against_reference(const std::vector<float>& d, int G, double bound, const CentroidOptions& o) {
  const Centroid c = density_centroid(d, G, bound, o);
  const Ref r = reference_centroid(d, G, bound, o);
  BOOST_REQUIRE(c.found == r.found);
  BOOST_TEST(c.cells == r.cells);
  if (r.found) BOOST_TEST(max_abs(c.centre, r.centre) < 1e-9 * bound);
}

// A checkpoint whose object NeRFs have a known density: frequency encoding without
// frequencies (the trunk sees x, y, z, t), two ReLU layers of 8, and object k's density
// sigma = peak * max(0, 1 - |p - c_k|_1 / r) in field (NDC) coordinates: an octahedron
// around c_k, the same at every time; colour red, blend 1.
struct KnownField {
  TrainConfig config;
  Checkpoint checkpoint;
  std::vector<Vec3> centres;  // NDC
  double radius = 0.1, peak = 200;
};
KnownField known_field(const Scene& scene, const RayGeometry& geo, const std::vector<Vec3>& centres) {
  KnownField k;
  k.centres = centres;
  TrainConfig& c = k.config;
  c = preset_config("quick");
  // The paper's field of (x, y, z, t), whose trunk reads the point and the time directly
  // (pos-freqs 0): the weights below give it a known density.
  set_config_value(c, "object-motion", "none");  // (and with it no object box)
  c.field.encoding = Encoding::Frequency;
  c.field.pos_freqs = 0;
  c.field.depth = 2;
  c.field.width = 8;
  c.field.skip = -1;
  c.occupancy = false;
  c.samples = 64;
  const size_t K = static_cast<size_t>(scene.num_objects);
  Graph g;
  build_object_fields(g.input("p", Shape{K, 4, 3}), g.input("t", Shape{K, 4, 1}), scene_field(c.field, geo));
  k.checkpoint.meta["objects"] = std::to_string(K);
  for (Tensor p : g.parameters()) {
    CheckpointArray a;
    a.name = p.info().name;
    a.shape = p.shape().dims;
    size_t n = 1;
    for (size_t d : a.shape) n *= d;
    a.values.assign(n, 0.0f);
    const size_t per = n / K;
    for (size_t o = 0; o < K; ++o) {
      float* v = a.values.data() + o * per;
      const Vec3& ck = centres.at(o);
      if (a.name == "objects.trunk.l0.w") {  // [4, 8]: units 2i, 2i+1 = +-p_i
        for (int i = 0; i < 3; ++i) {
          v[i * 8 + 2 * i] = 1.0f;
          v[i * 8 + 2 * i + 1] = -1.0f;
        }
      } else if (a.name == "objects.trunk.l0.b") {  // ReLU(+-(p_i - c_i)): |p_i - c_i| in two units
        for (int i = 0; i < 3; ++i) {
          v[2 * i] = static_cast<float>(-ck[i]);
          v[2 * i + 1] = static_cast<float>(ck[i]);
        }
      } else if (a.name == "objects.trunk.l1.w") {  // [8, 8]: unit 0 = ReLU(r - |p - c|_1)
        for (int j = 0; j < 6; ++j) v[j * 8] = -1.0f;
      } else if (a.name == "objects.trunk.l1.b") {
        v[0] = static_cast<float>(k.radius);
      } else if (a.name == "objects.trunk.out.w") {  // [8, 5]: sigma = peak / r * unit 0
        v[3] = static_cast<float>(k.peak / k.radius);
      } else if (a.name == "objects.trunk.out.b") {
        v[0] = 4.0f;
        v[1] = v[2] = -4.0f;
        v[4] = 8.0f;
      } else {
        BOOST_FAIL("unexpected object parameter " << a.name);
      }
    }
    k.checkpoint.arrays.push_back(std::move(a));
  }
  return k;
}

Vec3 world_to_ndc(const Vec3& w, const RayGeometry& geo) {
  return {geo.ax * w[0] / w[2], geo.ay * w[1] / w[2], 1 + 2 / w[2]};
}

struct MaskCentre {
  double x = 0, y = 0, mass = 0;
};
MaskCentre mask_centre(const ViewImage& img) {
  MaskCentre c;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const double a = img.acc[static_cast<size_t>(y) * img.width + x];
      c.mass += a;
      c.x += a * (x + 0.5);
      c.y += a * (y + 0.5);
    }
  if (c.mass > 0) {
    c.x /= c.mass;
    c.y /= c.mass;
  }
  return c;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(object_centre)

// Metric field, G = 48 over [-1.5, 1.5]^3 (cell 1/16). A ball or a Gaussian symmetric about
// its centre voxelises into cells whose centroid is off by at most half a cell per axis (the
// cells kept are symmetric up to the cell boundaries); the tolerance is that half cell
// (0.031; measured at most 0.0031).
BOOST_AUTO_TEST_CASE(symmetric_densities_in_a_metric_field) {
  const int G = 48;
  const double bound = 1.5, cell = 2 * bound / G;
  const CentroidOptions o;
  struct Case {
    const char* name;
    Density f;
    Vec3 centre;
  };
  const std::vector<Case> cases = {
      {"centred ball", ball({0, 0, 0}, 0.4, 40), {0, 0, 0}},
      {"off-centre ball", ball({0.63, -0.41, 0.27}, 0.3, 40), {0.63, -0.41, 0.27}},
      {"off-centre Gaussian", gaussian({-0.52, 0.33, 0.71}, {0.12, 0.12, 0.12}, 200), {-0.52, 0.33, 0.71}},
      {"elongated Gaussian", gaussian({0.2, 0.5, -0.6}, {0.35, 0.08, 0.15}, 300), {0.2, 0.5, -0.6}},
  };
  for (const Case& k : cases) {
    BOOST_TEST_CONTEXT(k.name) {
      const std::vector<float> d = sample_field(k.f, G, bound, o);
      check_against_reference(d, G, bound, o);
      const Centroid c = density_centroid(d, G, bound, o);
      BOOST_REQUIRE(c.found);
      BOOST_TEST_MESSAGE(k.name << ": " << c.cells << " cells, error " << max_abs(c.centre, k.centre));
      BOOST_TEST(max_abs(c.centre, k.centre) <= 0.5 * cell);
    }
  }
}

// An asymmetric object: two balls of different size and density. Its centre is the mass
// centre (m_i = sigma_i 4/3 pi r_i^3), not the midpoint of its parts. A voxelised ball of
// radius r cells (here 5 and 3.2) has a volume off by a few percent, which moves the mass
// centre by that fraction of the balls' distance (0.9): the tolerance is one cell (0.0625;
// measured error 0.003).
BOOST_AUTO_TEST_CASE(asymmetric_density_has_its_mass_centre) {
  const int G = 48;
  const double bound = 1.5, cell = 2 * bound / G;
  const CentroidOptions o;
  const Vec3 c1{-0.3, 0.1, 0.2}, c2{0.5, -0.2, -0.2};
  const double r1 = 0.3125, r2 = 0.2, s1 = 30, s2 = 400;
  const Density a = ball(c1, r1, s1), b = ball(c2, r2, s2);
  const std::vector<float> d = sample_field([&](const Vec3& p) { return a(p) + b(p); }, G, bound, o);
  check_against_reference(d, G, bound, o);
  const double m1 = s1 * r1 * r1 * r1, m2 = s2 * r2 * r2 * r2;
  Vec3 expect{};
  for (int k = 0; k < 3; ++k) expect[k] = (m1 * c1[k] + m2 * c2[k]) / (m1 + m2);
  const Centroid c = density_centroid(d, G, bound, o);
  BOOST_REQUIRE(c.found);
  BOOST_TEST_MESSAGE("two balls: error " << max_abs(c.centre, expect));
  BOOST_TEST(max_abs(c.centre, expect) <= cell);
  // Not the midpoint of the two balls: the denser one pulls (m2 = 3.5 m1).
  Vec3 mid{};
  for (int k = 0; k < 3; ++k) mid[k] = 0.5 * (c1[k] + c2[k]);
  BOOST_TEST(max_abs(c.centre, mid) > 3 * cell);
}

// NDC field (forward-facing scene, the rays' constants ax = -fx / cx, ay = -fy / cy, near
// plane 1): world objects 2-3 units in front of the camera. The centre comes back in world
// coordinates. A world cell at depth z spans 2/G |z / a| across and 2/G z^2 / 2 in depth;
// a symmetric world object voxelised in NDC is symmetric only up to those cells, and the
// NDC mean is the world centre only up to second order in the object's depth extent over
// its distance (NDC weighs its near side more): the tolerance per axis is half a world cell
// at the object's far side (measured: 0.033 of 0.063 in depth for the ball, 0.015 of 0.033
// for the Gaussian, each nearer the camera).
BOOST_AUTO_TEST_CASE(ndc_field_gives_world_centre) {
  const int G = 64;
  const double bound = 1.0, ndc_cell = 2 * bound / G;
  CentroidOptions o;
  o.ndc = true;
  o.ax = -2.1;
  o.ay = -2.8;
  struct Case {
    const char* name;
    Density f;
    Vec3 centre;
    double radius;
  };
  const std::vector<Case> cases = {
      {"ball", ball({0.3, -0.2, -2.5}, 0.35, 30), {0.3, -0.2, -2.5}, 0.35},
      {"Gaussian", gaussian({-0.4, 0.25, -1.8}, {0.1, 0.1, 0.1}, 300), {-0.4, 0.25, -1.8}, 0.25},
  };
  for (const Case& k : cases) {
    BOOST_TEST_CONTEXT(k.name) {
      const std::vector<float> d = sample_field(k.f, G, bound, o);
      check_against_reference(d, G, bound, o);
      const Centroid c = density_centroid(d, G, bound, o);
      BOOST_REQUIRE(c.found);
      const double zf = std::fabs(k.centre[2]) + k.radius;
      const Vec3 tol{0.5 * ndc_cell * zf / std::fabs(o.ax), 0.5 * ndc_cell * zf / std::fabs(o.ay),
                     0.5 * ndc_cell * zf * zf / 2};
      BOOST_TEST_MESSAGE(k.name << ": " << c.cells << " cells, centre " << c.centre[0] << ", " << c.centre[1]
                                << ", " << c.centre[2] << " (tolerance " << tol[0] << ", " << tol[1] << ", "
                                << tol[2] << ")");
      for (int a = 0; a < 3; ++a) BOOST_TEST(std::fabs(c.centre[a] - k.centre[a]) <= tol[a]);
      // field_centre is the same point in NDC.
      const Vec3 back = field_to_world(c.field_centre, o);
      BOOST_TEST(max_abs(back, c.centre) == 0.0);
    }
  }
}

// Density spread along the rays through an object up to the far plane (an object NeRF of a
// monocular video keeps such streaks, hidden behind the background): the centre stays at a
// finite depth in the streak, on the line of sight through the object (its image position
// x/z, y/z within half an NDC cell, divided by the NDC constants), where averaging world
// points would run off towards the far plane (depths up to 2 / (1 - z_ndc) = 64 units here).
BOOST_AUTO_TEST_CASE(ndc_streak_keeps_its_line_of_sight) {
  const int G = 64;
  const double bound = 1.0, ndc_cell = 2 * bound / G;
  CentroidOptions o;
  o.ndc = true;
  o.ax = -2.1;
  o.ay = -2.8;
  const Vec3 front{0.3, -0.2, -2.0};
  // A thin cone of rays through `front`: NDC x, y within 1.5 cells of the front's, from its
  // depth to the far plane.
  const double xn = o.ax * front[0] / front[2], yn = o.ay * front[1] / front[2], zn = 1 + 2 / front[2];
  std::vector<float> d(static_cast<size_t>(G) * G * G, 0.0f);
  for (size_t c = 0; c < d.size(); ++c) {
    const Vec3 p = probe_cell_centre(c, G, bound);
    if (std::fabs(p[0] - xn) < 1.5 * ndc_cell && std::fabs(p[1] - yn) < 1.5 * ndc_cell && p[2] >= zn) d[c] = 20.0f;
  }
  check_against_reference(d, G, bound, o);
  const Centroid c = density_centroid(d, G, bound, o);
  BOOST_REQUIRE(c.found);
  BOOST_TEST_MESSAGE("streak: centre " << c.centre[0] << ", " << c.centre[1] << ", " << c.centre[2]);
  BOOST_TEST(c.centre[2] < front[2]);
  BOOST_TEST(c.centre[2] > -10.0);  // the mean disparity's depth: 2 / (1 - (zn + 1) / 2) = -4 here
  BOOST_TEST(std::fabs(o.ax * c.centre[0] / c.centre[2] - xn) <= 0.5 * ndc_cell);
  BOOST_TEST(std::fabs(o.ay * c.centre[1] / c.centre[2] - yn) <= 0.5 * ndc_cell);
}

BOOST_AUTO_TEST_CASE(no_density_is_not_found) {
  const int G = 16;
  const double cell = 2.0 / G;
  std::vector<float> d(static_cast<size_t>(G) * G * G, 0.0f);
  BOOST_TEST(!density_centroid(d, G, 1.0).found);
  // Unprobed (negative), non-finite, and haze under the floor (alpha 0.01 over a cell) count
  // as nothing; the largest probed density is still reported.
  d[5] = -1.0f;
  d[6] = std::nanf("");
  d[7] = 0.9f * static_cast<float>(-std::log1p(-0.01) / cell);
  d[8] = 0.5f * d[7];
  Centroid c = density_centroid(d, G, 1.0);
  BOOST_TEST(!c.found);
  BOOST_TEST(c.cells == 0u);
  BOOST_TEST(c.max_density == static_cast<double>(d[7]));
  // A faint object (no cell 10% opaque, some over the floor) is centred on its densest cells
  // (over half its peak): here the cells 9 and 10, equally dense.
  d[9] = d[10] = 3.0f * static_cast<float>(-std::log1p(-0.01) / cell);
  c = density_centroid(d, G, 1.0);
  BOOST_REQUIRE(c.found);
  BOOST_TEST(c.cells == 2u);
  BOOST_TEST(std::fabs(c.centre[0] - (probe_cell_centre(9, G, 1.0)[0] + cell / 2)) < 1e-12);
  // Solid cells take over: 10% opaque counts even far under half the peak (cell 201), and
  // the faint cells 9 and 10 (3% opaque) drop out.
  d[200] = 1000.0f;
  d[201] = 125.0f;
  c = density_centroid(d, G, 1.0);
  BOOST_TEST(c.cells == 2u);
  check_against_reference(d, G, 1.0, {});
  // One opaque cell is its own centre, bit for bit on every call.
  std::vector<float> one(d.size(), 0.0f);
  one[100] = 50.0f;
  const Centroid a = density_centroid(one, G, 1.0), b = density_centroid(one, G, 1.0);
  BOOST_REQUIRE(a.found);
  BOOST_TEST(max_abs(a.centre, probe_cell_centre(100, G, 1.0)) == 0.0);
  BOOST_TEST(std::memcmp(a.centre.data(), b.centre.data(), sizeof a.centre) == 0);
}

// The whole path on a field of known density (known_field): the tiny scene's two objects as
// octahedra (NDC radius 0.1) around their true centres at the last frame (the ground truth's
// objects_only pivots, mapped to NDC). An instance without pivot= must turn about a point
// whose NDC image is the octahedron's centre within half a probe cell (1/64: the probe grid's
// cell centres are not symmetric about it; measured <= 2.1e-3), which lies inside the object,
// the same bits from a second renderer; and turning the object by (10, 0, 30) degrees about
// it keeps its rendered mask in place: the acc-weighted mask centroid on the 64x48 view
// moves less than 1 px (measured <= 0.12 px: the octahedron's image changes shape as it
// turns), while the same turn about the scene origin moves it more than 5 px or out of the
// view (measured 11 and 18 px), the behaviour the default pivot replaced.
BOOST_AUTO_TEST_CASE(default_pivot_is_the_object_centre) {
  LoadOptions lo;
  lo.load_gt = true;
  const Scene scene = load_scene(nova::test::cached_tiny_scene().string(), lo);
  const RayGeometry geo = ray_geometry(scene);
  BOOST_REQUIRE(geo.ndc);
  const ComposeTarget* target = nullptr;
  for (const ComposeTarget& t : scene.compose.targets)
    if (t.name == "objects_only") target = &t;
  BOOST_REQUIRE(target);
  BOOST_REQUIRE(static_cast<int>(target->instances.size()) == scene.num_objects);
  std::vector<Vec3> centres;
  for (const ComposeInstance& i : target->instances) centres.push_back(world_to_ndc(*i.pivot, geo));
  const KnownField f = known_field(scene, geo, centres);
  ViewRenderer r(runtime(), f.config, geo, f.checkpoint), again(runtime(), f.config, geo, f.checkpoint);
  BOOST_REQUIRE(!r.skips_empty_space());  // every cell of the 64^3 probe grid
  const double half_cell = 0.5 * 2.0 / ViewRenderer::kCentreProbeResolution;
  for (const ComposeInstance& truth : target->instances) {
    BOOST_TEST_CONTEXT("object " << truth.object) {
      ComposeInstance plain = truth;
      plain.pivot.reset();
      const InstancePivot pv = r.pivot_for(plain);
      BOOST_REQUIRE((pv.from == InstancePivot::From::Density));
      const InstancePivot pv2 = again.pivot_for(plain);
      BOOST_TEST(std::memcmp(pv.pivot.data(), pv2.pivot.data(), sizeof pv.pivot) == 0);
      const Vec3 c = centres[static_cast<size_t>(truth.object - 1)];
      const Vec3 n = world_to_ndc(pv.pivot, geo);
      double l1 = 0;
      for (int d = 0; d < 3; ++d) l1 += std::fabs(n[d] - c[d]);
      BOOST_TEST(max_abs(n, c) <= half_cell);
      BOOST_TEST(l1 < f.radius);  // inside the object
      ComposeInstance turned = plain;
      turned.rotate_deg = {10, 0, 30};
      const auto view = [&](const ComposeInstance& inst, const std::array<double, 3>& pivot) {
        ViewRequest req;
        req.camera = scene.frames[static_cast<size_t>(target->camera)].camera;
        req.background = false;
        req.instances.push_back(placed_instance(inst, pivot));
        return mask_centre(r.render(req));
      };
      const MaskCentre still = view(plain, pv.pivot), about_centre = view(turned, pv.pivot),
                       about_origin = view(turned, {0, 0, 0});
      BOOST_REQUIRE(still.mass > 5);
      const double moved = std::hypot(about_centre.x - still.x, about_centre.y - still.y);
      const bool left = about_origin.mass < 0.2 * still.mass;
      const double flung = left ? 1e9 : std::hypot(about_origin.x - still.x, about_origin.y - still.y);
      BOOST_TEST_MESSAGE("object " << truth.object << ": pivot " << pv.pivot[0] << ", " << pv.pivot[1] << ", "
                                   << pv.pivot[2] << " (true " << (*truth.pivot)[0] << ", " << (*truth.pivot)[1]
                                   << ", " << (*truth.pivot)[2] << "), NDC error " << max_abs(n, c) << "; mask "
                                   << still.mass << " px at " << still.x << ", " << still.y << " moves " << moved
                                   << " px turned about it, "
                                   << (left ? std::string("leaves the view") : std::to_string(flung) + " px")
                                   << " about the origin");
      BOOST_TEST(about_centre.mass > 0.5 * still.mass);
      BOOST_TEST(moved < 1.0);
      BOOST_TEST(flung > 5.0);
    }
  }
}

BOOST_AUTO_TEST_SUITE_END()

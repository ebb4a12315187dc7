// The "family" preset's sampler: the seed draws a whole scene (see synth.hpp). Every draw
// comes from one std::mt19937 in a fixed order through our own uniform mapping, so a seed
// gives the same scene on every platform.
#include <algorithm>
#include <random>
#include <sstream>

#include "data/synth_geometry.hpp"
#include "nova/runtime/error.hpp"

namespace nova {
namespace {

using namespace synth;

class Draw {
 public:
  explicit Draw(uint32_t seed) : rng_(seed) {}
  // 53-bit uniform in [0, 1): std::uniform_real_distribution is not specified bit-exactly.
  double unit() {
    const uint64_t a = rng_() >> 5, b = rng_() >> 6;
    return double(a * 67108864ull + b) * (1.0 / 9007199254740992.0);
  }
  double uniform(double lo, double hi) { return lo + (hi - lo) * unit(); }
  int integer(int lo, int hi) { return std::min(hi, lo + int(unit() * (hi - lo + 1))); }
  bool chance(double p) { return unit() < p; }
  double sign() { return chance(0.5) ? 1.0 : -1.0; }
  uint32_t bits() { return rng_(); }
  V3 unit_vector() {
    const double z = uniform(-1, 1), a = uniform(0, 2 * kPi), s = std::sqrt(1 - z * z);
    return {s * std::cos(a), s * std::sin(a), z};
  }

 private:
  std::mt19937 rng_;
};

V3 hsv(double h, double s, double v) {
  h = h - std::floor(h);
  const double c = v * s, x = c * (1 - std::abs(std::fmod(h * 6, 2.0) - 1)), m = v - c;
  const int sector = std::min(5, int(h * 6));
  const V3 table[6] = {{c, x, 0}, {x, c, 0}, {0, c, x}, {0, x, c}, {x, 0, c}, {c, 0, x}};
  return add(table[sector], {m, m, m});
}

// A texture in two colours around hue `hue`; `scale` is the surface's size, so patterns
// show a few cycles across it whatever its size.
// On a plane (flat_axis: its normal's axis) the pattern direction lies in the plane, so the
// pattern cannot come out constant.
SynthTexture draw_texture(Draw& g, double hue, double saturation, double scale, int flat_axis = -1) {
  SynthTexture t;
  t.kind = static_cast<SynthTextureKind>(g.integer(0, 3));
  const double v = g.uniform(0.55, 0.95);
  t.colour_a = hsv(hue, saturation, v);
  // One draw per statement: the order of evaluation of call arguments is unspecified.
  const double hue_step = g.uniform(0.1, 0.4), hue_sign = g.sign();
  const double sat_b = saturation * g.uniform(0.4, 1.0);
  const double v_b = std::clamp(v + g.uniform(0.25, 0.45) * (v > 0.75 ? -1 : 1), 0.15, 1.0);
  t.colour_b = hsv(hue + hue_step * hue_sign, sat_b, v_b);
  const double cycles = t.kind == SynthTextureKind::gradient ? g.uniform(0.8, 1.6)
                                                             : g.uniform(1.5, 4.0);
  t.frequency = cycles / (2 * scale);
  t.direction = g.unit_vector();
  if (flat_axis >= 0) {
    t.direction[size_t(flat_axis)] = 0;
    t.direction = dot(t.direction, t.direction) > 1e-6 ? normalize(t.direction) : V3{1, 0, 0};
      }
  for (int k = 0; k < 3; ++k) t.phase[size_t(k)] = g.unit();
  return t;
}

SynthShape draw_shape(Draw& g, SynthShapeKind kind, double r) {
  // `r` is the bounding radius to aim for; proportions are drawn within each kind.
  SynthShape s{kind, {r, r, r}};
  switch (kind) {
    case SynthShapeKind::sphere: s.size = {r, r, r}; break;
    case SynthShapeKind::box: {
      const V3 e{g.uniform(0.5, 1), g.uniform(0.5, 1), g.uniform(0.5, 1)};
      s.size = mul(e, r / std::sqrt(dot(e, e)));
      break;
    }
    case SynthShapeKind::cylinder: {
      const double a = g.uniform(0.35, 0.8);
      s.size = {r * a, r * std::sqrt(1 - a * a), 0};
      break;
    }
    case SynthShapeKind::torus: {
      const double minor = g.uniform(0.2, 0.35);
      s.size = {r * (1 - minor), r * minor, 0};
      break;
    }
    case SynthShapeKind::disc: s.size = {r * 0.97, r * g.uniform(0.04, 0.08), 0}; break;
    case SynthShapeKind::rod: s.size = {r * g.uniform(0.06, 0.1), r * 0.98, 0}; break;
    case SynthShapeKind::dumbbell: {
      const double ball = g.uniform(0.3, 0.4);
      s.size = {r * ball, r * (1 - ball), r * ball * g.uniform(0.3, 0.5)};
      break;
    }
    case SynthShapeKind::ell: {
      const double w = g.uniform(0.15, 0.22), a = g.uniform(0.5, 0.8);
      const double b = std::sqrt(std::max(0.1, 1 - a * a - w * w));
      s.size = {r * a, r * b, r * w};
      break;
    }
  }
  return s;
}

const char* imperfection_mask_words(int grow) {
  return grow > 0 ? "dilated" : "eroded";
}

}  // namespace

SynthScene draw_family_scene(uint32_t seed) {
  Draw g(seed);
  SynthScene s;
  s.seed = seed;

  // Size: small enough for a 2-core CPU, aspect ratios 4:3 to 16:9.
  static const int kSizes[6][2] = {{128, 96}, {160, 90}, {160, 120}, {176, 99}, {144, 108}, {192, 108}};
  const int size = g.integer(0, 5);
  SynthPreset& p = s.preset;
  p.name = "family";
  p.width = kSizes[size][0];
  p.height = kSizes[size][1];
  p.frames = g.integer(12, 16);
  const double fov = g.uniform(45, 65) * kPi / 180;
  p.focal = 0.5 * p.width / std::tan(0.5 * fov);
  const double tan_x = 0.5 * p.width / p.focal, tan_y = 0.5 * p.height / p.focal;

  // Background: a wall at finite depth in front of the cameras (forward-facing), a floor,
  // static props near the wall.
  SynthBackground& bg = s.background;
  bg.wall_z = -g.uniform(4.5, 8.0);
  bg.floor_y = -g.uniform(1.0, 1.8);
  const double wall = -bg.wall_z, bg_hue = g.unit();
  bg.wall = draw_texture(g, bg_hue, g.uniform(0.15, 0.45), 2.5, 2);
  bg.floor = draw_texture(g, bg_hue + 0.5, g.uniform(0.15, 0.45), 1.5, 1);
  const int props = g.integer(1, 3);
  for (int k = 0; k < props; ++k) {
    SynthProp prop;
    const auto kind = std::array{SynthShapeKind::sphere, SynthShapeKind::box,
                                 SynthShapeKind::cylinder}[size_t(g.integer(0, 2))];
    const double r = g.uniform(0.25, 0.55);
    prop.shape = draw_shape(g, kind, r);
    // Resting on the floor, within 1 of the wall, anywhere across the wall's visible width.
    const double half_h = kind == SynthShapeKind::sphere ? prop.shape.size[0] : prop.shape.size[1];
    const double z = bg.wall_z + synth_bounding_radius(prop.shape) + g.uniform(0.05, 0.3);
    // Props do not overlap: redraw the position a few times, then leave the prop out.
    bool placed = false;
    for (int attempt = 0; attempt < 8 && !placed; ++attempt) {
      prop.centre = {g.uniform(-0.8, 0.8) * wall * tan_x, bg.floor_y + half_h, z};
      placed = true;
      for (const SynthProp& q : bg.props) {
        const double gap = synth_bounding_radius(q.shape) + synth_bounding_radius(prop.shape) + 0.05;
        const V3 dq = sub(q.centre, prop.centre);
        placed = placed && dot(dq, dq) > gap * gap;
      }
    }
    const double prop_hue = g.unit(), prop_sat = g.uniform(0.3, 0.6);
    prop.texture = draw_texture(g, prop_hue, prop_sat, r);
    if (placed) bg.props.push_back(prop);
  }

  // Camera path: camera centres near the origin, all looking at `target` on the far side.
  SynthCameraPath& cam = s.camera;
  cam.kind = static_cast<SynthCameraKind>(g.integer(1, 3));
  const double cam_y = g.uniform(-0.2, 0.3);
  const double pivot = g.uniform(0.5, 0.8) * wall;
  cam.target = {g.uniform(-0.3, 0.3), cam_y - g.uniform(0.0, 0.3), -pivot};
  const int n = p.frames;
  const double dir = g.sign();
  auto arc_point = [&](double angle) {
    return V3{cam.target[0] + pivot * std::sin(angle), cam_y, cam.target[2] + pivot * std::cos(angle)};
  };
  if (cam.kind == SynthCameraKind::slide) {
    const double span = g.uniform(0.06, 0.15) * wall, wobble = g.uniform(0.0, 0.04);
    const double dz = g.uniform(-0.25, 0.25), ph = g.unit();
    for (int i = 0; i < n; ++i) {
      const double u = double(i) / (n - 1);
      cam.positions.push_back({dir * span * (u - 0.5), cam_y + wobble * std::sin(2 * kPi * (u + ph)), dz * u + 0.0});  // + 0.0: no -0 in synth.txt
    }
  } else if (cam.kind == SynthCameraKind::arc) {
    const double half = g.uniform(5, 12) * kPi / 180;
    for (int i = 0; i < n; ++i) cam.positions.push_back(arc_point(dir * half * (2.0 * i / (n - 1) - 1)));
  } else {
    cam.rig_cameras = g.integer(4, 8);
    cam.rig_on_arc = g.chance(0.5);
    const int c = cam.rig_cameras;
    const double baseline = g.uniform(0.015, 0.03) * wall;
    std::vector<V3> rig;
    for (int k = 0; k < c; ++k) {
      const double x = dir * baseline * (k - 0.5 * (c - 1));
      rig.push_back(cam.rig_on_arc ? arc_point(x / pivot) : V3{x, cam_y, 0});
    }
    for (int i = 0; i < n; ++i) cam.positions.push_back(rig[size_t(i % c)]);
  }
  {
    // Held out: above and below the path's middle, off the path.
    const V3 mid = mul(add(cam.positions.front(), cam.positions.back()), 0.5);
    const double lift = g.uniform(0.04, 0.07) * wall;
    cam.heldout = {add(mid, {g.uniform(-0.01, 0.01) * wall, lift, 0.05}),
                   add(mid, {g.uniform(0.3, 0.6) * lift * dir, -0.8 * lift, -0.1})};
  }

  // Objects at distinct depths (slots in random order), each crossing the view in the
  // direction opposite to the previous one, so nearer ones pass in front of farther ones.
  const int k_objects = g.integer(1, 3);
  // Props end within 1.4 of the wall; the nearest object surface stays beyond 1.4.
  const double z_near = std::max(1.4, 0.25 * wall), z_far = std::min(0.85 * wall, wall - 1.5);
  const double slot = (z_far - z_near) / k_objects;
  std::vector<int> order(static_cast<size_t>(k_objects));
  for (int k = 0; k < k_objects; ++k) order[size_t(k)] = k;
  for (int k = k_objects - 1; k > 0; --k) std::swap(order[size_t(k)], order[size_t(g.integer(0, k))]);
  const double hue0 = g.unit(), first_dir = g.sign();
  for (int k = 0; k < k_objects; ++k) {
    SynthObject obj;
    const double depth = z_near + slot * (order[size_t(k)] + 0.5);
    const double half_w = depth * tan_x, half_h = depth * tan_y;
    const double r = std::min(g.uniform(0.12, 0.3) * half_w, 0.45 * slot);
    const auto kind = static_cast<SynthShapeKind>(g.integer(0, 7));
    obj.shape = draw_shape(g, kind, r);
    const double hue = hue0 + double(k) / k_objects + g.uniform(-0.05, 0.05);
    const double saturation = g.uniform(0.55, 0.9);
    obj.texture = draw_texture(g, hue, saturation, r);
    const double z = -depth + g.uniform(-0.5, 0.5) * std::max(0.0, slot - 2 * r);
    const double y_lo = std::max(bg.floor_y + r + 0.05, cam_y - 0.6 * half_h);
    const double y_hi = std::max(y_lo, cam_y + 0.5 * half_h);
    const double sgn = first_dir * (k % 2 ? -1 : 1);
    // Some paths run past the frame's edge, so the object leaves it partly.
    const double reach0 = g.chance(0.3) ? g.uniform(0.95, 1.15) : g.uniform(0.3, 0.8);
    const double reach1 = g.chance(0.3) ? g.uniform(0.95, 1.15) : g.uniform(0.3, 0.8);
    SynthMotion& m = obj.motion;
    m.p0 = {-sgn * reach0 * half_w + cam.target[0] * depth / pivot, g.uniform(y_lo, y_hi), z};
    m.p2 = {sgn * reach1 * half_w + cam.target[0] * depth / pivot, g.uniform(y_lo, y_hi), -depth + g.uniform(-0.5, 0.5) * std::max(0.0, slot - 2 * r)};
    if (g.chance(0.5)) {
      m.kind = SynthMotionKind::bezier;
      const V3 mid = mul(add(m.p0, m.p2), 0.5);
      const double bend = std::min(y_hi - mid[1], mid[1] - y_lo) * 1.6;
      m.p1 = {mid[0] + g.uniform(-0.2, 0.2) * half_w, mid[1] + g.uniform(-1, 1) * bend, mid[2]};
    } else {
      m.kind = SynthMotionKind::sinusoid;
      const double amp = std::min(y_hi - std::max(m.p0[1], m.p2[1]), std::min(m.p0[1], m.p2[1]) - y_lo);
      m.p1 = {0, std::max(0.0, amp) * g.uniform(0.3, 1.0), 0};
      m.frequency = g.uniform(0.5, 1.5);
      m.phase = {g.unit(), 0};
    }
    m.spin_axis = g.unit_vector();
    const double spin_sign = g.sign();
    m.spin_rate = spin_sign * g.uniform(0.5, 3.5);
    m.spin_phase = g.unit();
    s.objects.push_back(obj);
  }
  // Composition offsets scaled to object 1, so a moved object stays in view.
  const double r1 = synth_bounding_radius(s.objects[0].shape);
  s.compose_shift = {1.3 * r1, 0.9 * r1, 0};
  s.compose_copy_shift = {0, 1.1 * r1, 0.6 * r1};

  // Imperfections of the training inputs; about a quarter of the scenes stay clean.
  SynthImperfections& imp = s.imperfections;
  imp.noise_seed = g.bits();
  if (!g.chance(0.25)) {
    const bool mask = g.chance(0.55), disp = g.chance(0.55), gain = g.chance(0.5);
    if (mask) {
      if (g.chance(0.75)) {
        const int px = g.integer(1, 3);
        imp.mask_grow = g.chance(0.5) ? px : -px;
      }
      imp.mask_jagged = imp.mask_grow == 0 || g.chance(0.5);
    }
    // With nothing drawn, the disparity is the imperfection (the commonest one in practice).
    if (disp || (!mask && !gain)) {
      imp.disparity = true;
      imp.disp_scale = std::exp(g.uniform(std::log(0.3), std::log(3.0)));
      imp.disp_shift = g.uniform(0.0, 0.3) / wall;
      imp.disp_sigma = g.uniform(1.0, 3.0);
    }
    if (gain) {
      const double amp = g.uniform(0.02, 0.06);
      for (int i = 0; i < n; ++i) imp.gains.push_back(1 + amp * g.uniform(-1, 1));
    }
  }
  return s;
}

SynthScene draw_deforming_scene(uint32_t seed) {
  SynthScene s = draw_family_scene(seed);
  s.preset.name = "deforming";
  // A stream of its own (the seed's bits mixed with a constant), so that the family's draws
  // stay as they are.
  Draw g(seed ^ 0x9e3779b9u);
  for (SynthObject& obj : s.objects) {
    SynthMotion& m = obj.motion;
    const int axis = g.integer(0, 2);
    const double amplitude = g.uniform(0.25, 0.45);
    for (int a = 0; a < 3; ++a) m.stretch[size_t(a)] = a == axis ? amplitude : -0.5 * amplitude;
    m.stretch_rate = g.uniform(0.75, 1.5);
    m.stretch_phase = g.unit();
  }
  return s;
}

std::string describe_synth_scene(const SynthScene& s) {
  std::ostringstream o;
  o.precision(4);
  const SynthPreset& p = s.preset;
  const double fov = 2 * std::atan(0.5 * p.width / p.focal) * 180 / kPi;
  o << "scene " << p.frames << " frames at " << p.width << "x" << p.height << ", horizontal fov "
    << fov << " deg\n";
  const auto& bg = s.background;
  o << "background wall z " << bg.wall_z << " (" << synth_texture_name(bg.wall.kind) << "), floor y "
    << bg.floor_y << " (" << synth_texture_name(bg.floor.kind) << "), props";
  for (const auto& pr : bg.props)
    o << " " << synth_shape_name(pr.shape.kind) << "@(" << pr.centre[0] << "," << pr.centre[1] << ","
      << pr.centre[2] << ")";
  o << "\n";
  const auto& c = s.camera;
  o << "camera " << synth_camera_name(c.kind);
  if (c.kind == SynthCameraKind::rig)
    o << " of " << c.rig_cameras << " cameras on " << (c.rig_on_arc ? "an arc" : "a line")
      << ", baseline "
      << std::sqrt(dot(sub(c.positions[1 % c.positions.size()], c.positions[0]),
                       sub(c.positions[1 % c.positions.size()], c.positions[0])));
  o << ", from (" << c.positions.front()[0] << "," << c.positions.front()[1] << ","
    << c.positions.front()[2] << ") looking at (" << c.target[0] << "," << c.target[1] << ","
    << c.target[2] << ")\n";
  for (size_t k = 0; k < s.objects.size(); ++k) {
    const SynthObject& ob = s.objects[k];
    const SynthMotion& m = ob.motion;
    const SynthVec c0 = m.kind == SynthMotionKind::bezier || m.kind == SynthMotionKind::sinusoid
                            ? m.p0 : SynthVec{0, 0, 0};
    o << "object " << k + 1 << " " << synth_shape_name(ob.shape.kind) << " size ("
      << ob.shape.size[0] << "," << ob.shape.size[1] << "," << ob.shape.size[2] << ") radius "
      << synth_bounding_radius(ob.shape) << ", " << synth_texture_name(ob.texture.kind);
    if (m.kind == SynthMotionKind::bezier)
      o << ", bezier";
    else if (m.kind == SynthMotionKind::sinusoid)
      o << ", sinusoid (" << m.frequency << " cycles, amplitude " << m.p1[1] << ")";
    else
      o << ", fixed path";
    if (m.kind == SynthMotionKind::bezier || m.kind == SynthMotionKind::sinusoid)
      o << " from (" << c0[0] << "," << c0[1] << "," << c0[2] << ") to (" << m.p2[0] << ","
        << m.p2[1] << "," << m.p2[2] << "), depth ratio " << -c0[2] / -bg.wall_z;
    o << ", spin " << m.spin_rate << " rad";
    if (m.stretch[0] != 0 || m.stretch[1] != 0 || m.stretch[2] != 0)
      o << ", stretch (" << m.stretch[0] << "," << m.stretch[1] << "," << m.stretch[2] << ") x "
        << m.stretch_rate << " cycles";
    o << "\n";
  }
  const auto& imp = s.imperfections;
  o << "imperfections";
  if (!imp.any()) o << " none (clean)";
  if (imp.mask_grow) o << " masks-" << imperfection_mask_words(imp.mask_grow) << "-" << std::abs(imp.mask_grow) << "px";
  if (imp.mask_jagged) o << " masks-jagged";
  if (imp.disparity)
    o << " disparity-affine(scale " << imp.disp_scale << ", shift " << imp.disp_shift << ")-blur(sigma "
      << imp.disp_sigma << "px)";
  if (!imp.gains.empty()) {
    double lo = 1e9, hi = 0;
    for (double v : imp.gains) lo = std::min(lo, v), hi = std::max(hi, v);
    o << " exposure-gain(" << lo << " to " << hi << ")";
  }
  o << "\n";
  return o.str();
}

}  // namespace nova

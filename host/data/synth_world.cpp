// The analytic world of the synthetic scenes (see include/nova/data/synth.hpp): the fixed presets'
// scene, procedural textures, motion and a one-ray-per-pixel ray tracer. Plain double
// arithmetic in a fixed order, one thread, so equal inputs give equal bytes.
#include <algorithm>
#include <random>

#include "data/synth_geometry.hpp"
#include "nova/runtime/error.hpp"

namespace nova {
namespace {

using namespace synth;

Camera look_at(const SynthPreset& p, V3 pos, V3 target) {
  const V3 back = normalize(sub(pos, target));
  const V3 right = normalize(cross({0, 1, 0}, back));
  const V3 up = cross(back, right);
  Camera c;
  c.width = p.width;
  c.height = p.height;
  c.fx = c.fy = p.focal;
  c.cx = 0.5 * p.width;
  c.cy = 0.5 * p.height;
  c.c2w = {right[0], up[0], back[0], pos[0], right[1], up[1], back[1], pos[1],
           right[2], up[2], back[2], pos[2]};
  return c;
}

// World -> local for a rigid pose: R^T (p - c); directions: R^T d.
V3 to_local_point(const Pose34& m, V3 p) {
  const V3 q{p[0] - m[3], p[1] - m[7], p[2] - m[11]};
  return {m[0] * q[0] + m[4] * q[1] + m[8] * q[2], m[1] * q[0] + m[5] * q[1] + m[9] * q[2],
          m[2] * q[0] + m[6] * q[1] + m[10] * q[2]};
}
V3 to_local_dir(const Pose34& m, V3 d) {
  return {m[0] * d[0] + m[4] * d[1] + m[8] * d[2], m[1] * d[0] + m[5] * d[1] + m[9] * d[2],
          m[2] * d[0] + m[6] * d[1] + m[10] * d[2]};
}
V3 to_world_dir(const Pose34& m, V3 d) {
  return {m[0] * d[0] + m[1] * d[1] + m[2] * d[2], m[4] * d[0] + m[5] * d[1] + m[6] * d[2],
          m[8] * d[0] + m[9] * d[1] + m[10] * d[2]};
}

double shade(V3 n) {
  static const V3 light = normalize({0.35, 0.8, 0.5});
  return 0.6 + 0.4 * std::max(0.0, dot(n, light));
}

uint8_t to8(double v) { return static_cast<uint8_t>(std::lround(std::clamp(v, 0.0, 1.0) * 255.0)); }

// Albedo at a surface point p with unit normal n, both in the surface's own frame (world
// frame for the wall and the floor). `half` is a box's half size (legacy box texture).
V3 albedo(const SynthTexture& tex, V3 p, V3 n, double half) {
  const auto& r = tex.phase;
  switch (tex.kind) {
    case SynthTextureKind::legacy_wall: {
      const double x = p[0], y = p[1];
      return {0.55 + 0.25 * std::sin(2 * kPi * (0.6 * x + r[0])) * std::cos(2 * kPi * (0.45 * y + r[1])) +
                  0.1 * std::sin(2 * kPi * (1.3 * y + 0.5 * x + r[2])),
              0.5 + 0.25 * std::sin(2 * kPi * (0.5 * y + r[3])) + 0.12 * std::cos(2 * kPi * (1.1 * x + r[4])),
              0.45 + 0.25 * std::cos(2 * kPi * (0.5 * x - 0.8 * y + r[5]))};
    }
    case SynthTextureKind::legacy_floor: {
      const double s = std::tanh(3.0 * std::sin(kPi * (1.2 * p[0] + r[0])) * std::sin(kPi * (1.2 * p[2] + r[1])));
      return mix(tex.colour_a, tex.colour_b, 0.5 + 0.5 * s);
    }
    case SynthTextureKind::legacy_prop_sphere: {
      const double s = 0.5 + 0.5 * std::sin(7.0 * std::atan2(n[2], n[0]) + 2 * kPi * r[0]);
      return mix(tex.colour_a, tex.colour_b, s);
    }
    case SynthTextureKind::legacy_striped_sphere: {
      const double lon = std::atan2(n[2], n[0]), lat = std::asin(std::clamp(n[1], -1.0, 1.0));
      const double m = 0.5 + 0.5 * std::tanh(4.0 * std::sin(3.0 * lon + 2 * kPi * r[0]));
      return mul(mix(tex.colour_a, tex.colour_b, m), 0.75 + 0.25 * std::cos(6.0 * lat));
    }
    case SynthTextureKind::legacy_checkered_box: {
      int axis = 0;
      for (int k = 0; k < 3; ++k)
        if (n[k] != 0) axis = k;
      const double a = p[(axis + 1) % 3] / half, b = p[(axis + 2) % 3] / half;
      const double s = std::tanh(3.0 * std::sin(kPi * (a + r[0])) * std::sin(kPi * (b + r[1])));
      const V3 base = axis == 1 ? tex.colour_a : tex.colour_b;
      return mix(base, {0.92, 0.92, 0.88}, 0.5 + 0.4 * s);
    }
    case SynthTextureKind::stripes: {
      const double s = std::sin(2 * kPi * (tex.frequency * dot(p, tex.direction) + r[0]));
      return mix(tex.colour_a, tex.colour_b, 0.5 + 0.5 * std::tanh(4.0 * s));
    }
    case SynthTextureKind::checks: {
      // Checks on the two coordinates across the dominant normal axis (a cube map): a plane
      // gets plain checks, a curved surface checks with seams.
      int axis = 0;
      for (int k = 1; k < 3; ++k)
        if (std::abs(n[k]) > std::abs(n[axis])) axis = k;
      const double f = 2 * kPi * tex.frequency;
      const double s = std::sin(f * p[(axis + 1) % 3] + 2 * kPi * r[0]) *
                       std::sin(f * p[(axis + 2) % 3] + 2 * kPi * r[1]);
      return mix(tex.colour_a, tex.colour_b, 0.5 + 0.5 * std::tanh(6.0 * s));
    }
    case SynthTextureKind::noise: {
      // A few sines along fixed skew directions: smooth, irregular, no lattice to hash.
      const double f = 2 * kPi * tex.frequency;
      const double s = 0.45 * std::sin(f * (0.8 * p[0] + 0.6 * p[1]) + 2 * kPi * r[0]) +
                       0.3 * std::sin(f * (1.7 * p[1] - 1.1 * p[2]) + 2 * kPi * r[1]) +
                       0.25 * std::sin(f * (2.3 * p[2] + 1.9 * p[0] - 0.7 * p[1]) + 2 * kPi * r[2]);
      return mix(tex.colour_a, tex.colour_b, std::clamp(0.5 + s, 0.0, 1.0));
    }
    case SynthTextureKind::gradient: {
      // A ramp along the direction with faint bands, so flat regions still carry parallax.
      const double u = tex.frequency * dot(p, tex.direction) + r[0];
      const double ramp = 0.5 + 0.5 * std::tanh(u);
      return mul(mix(tex.colour_a, tex.colour_b, ramp), 0.88 + 0.12 * std::cos(6 * kPi * u));
    }
  }
  throw Error("synthetic texture: unknown kind");
}

// The fixed world of "tiny" and "default": the seed only varies phases and jitter.
SynthScene fixed_scene(const std::string& preset, uint32_t seed) {
  SynthScene s;
  s.preset = synth_preset(preset);
  s.seed = seed;
  // Our own uniform mapping: std::uniform_real_distribution is not specified bit-exactly.
  double r[32];
  std::mt19937 rng(seed);
  for (double& v : r) v = double(rng() >> 8) * (1.0 / 16777216.0);

  SynthBackground& b = s.background;
  b.wall_z = -6.0;
  b.floor_y = -1.4;
  b.wall.kind = SynthTextureKind::legacy_wall;
  b.wall.phase = {r[0], r[1], r[2], r[3], r[4], r[5]};
  b.floor.kind = SynthTextureKind::legacy_floor;
  b.floor.colour_a = {0.3, 0.35, 0.45};
  b.floor.colour_b = {0.8, 0.72, 0.55};
  b.floor.phase = {r[6], r[7]};
  SynthProp prop;
  prop.shape = {SynthShapeKind::sphere, {0.65, 0.65, 0.65}};
  prop.centre = {1.3 + 0.2 * (r[14] - 0.5), -0.75, -4.4};
  prop.texture.kind = SynthTextureKind::legacy_prop_sphere;
  prop.texture.colour_a = {0.45, 0.2, 0.55};
  prop.texture.colour_b = {0.35, 0.7, 0.45};
  prop.texture.phase = {r[15]};
  b.props.push_back(prop);

  SynthObject o1;
  o1.shape = {SynthShapeKind::sphere, {0.42, 0.42, 0.42}};
  o1.texture.kind = SynthTextureKind::legacy_striped_sphere;
  o1.texture.colour_a = {0.85, 0.15, 0.1};
  o1.texture.colour_b = {0.95, 0.85, 0.2};
  o1.texture.phase = {r[16]};
  o1.motion.kind = SynthMotionKind::legacy_object1;
  o1.motion.phase = {r[8], r[9]};
  o1.motion.spin_axis = {0.2, 1.0, 0.1};
  o1.motion.spin_rate = 3.0;
  o1.motion.spin_phase = r[10];
  SynthObject o2;
  o2.shape = {SynthShapeKind::box, {0.3, 0.3, 0.3}};
  o2.texture.kind = SynthTextureKind::legacy_checkered_box;
  o2.texture.colour_a = {0.1, 0.45, 0.9};
  o2.texture.colour_b = {0.15, 0.75, 0.35};
  o2.texture.phase = {r[17], r[18]};
  o2.motion.kind = SynthMotionKind::legacy_object2;
  o2.motion.phase = {r[11], r[12]};
  o2.motion.spin_axis = {0.4, 1.0, 0.3};
  o2.motion.spin_rate = 2.5;
  o2.motion.spin_phase = r[13];
  s.objects = {o1, o2};

  SynthCameraPath& c = s.camera;
  c.kind = SynthCameraKind::legacy_slide;
  const int n = s.preset.frames;
  for (int frame = 0; frame < n; ++frame) {
    const double u = n > 1 ? double(frame) / (n - 1) : 0.0;
    c.positions.push_back({-0.35 + 0.7 * u + 0.04 * (r[20] - 0.5) * std::sin(7.0 * frame),
                           0.06 * std::sin(kPi * u + 2 * kPi * r[21]), 0.15 * u});
  }
  c.target = {0.2 * (r[22] - 0.5), -0.15, -5.0};
  c.heldout = {{0.0, 0.35, 0.05}, {0.15, -0.3, -0.1}};
  return s;
}

V3 motion_centre(const SynthMotion& m, double u) {
  const auto& r = m.phase;
  switch (m.kind) {
    case SynthMotionKind::legacy_object1:
      return {-1.0 + 1.8 * u + 0.2 * (r[0] - 0.5), -0.35 + 0.22 * std::sin(2 * kPi * (u + r[1])), -3.6};
    case SynthMotionKind::legacy_object2:
      return {0.55 - 1.0 * u + 0.2 * (r[0] - 0.5), 0.4 + 0.1 * std::cos(2 * kPi * (u + r[1])),
              -2.3 - 0.25 * u};
    case SynthMotionKind::bezier: {
      const double a = (1 - u) * (1 - u), b = 2 * u * (1 - u), c = u * u;
      return add(add(mul(m.p0, a), mul(m.p1, b)), mul(m.p2, c));
    }
    case SynthMotionKind::sinusoid:
      return add(add(m.p0, mul(sub(m.p2, m.p0), u)),
                 mul(m.p1, std::sin(2 * kPi * (m.frequency * u + r[0]))));
  }
  throw Error("synthetic motion: unknown kind");
}

}  // namespace

void check_synth_preset(const std::string& name) {
  if (name != "tiny" && name != "default" && name != "family" && name != "deforming")
    throw Error("unknown synthetic preset '" + name + "' (use tiny, default, family or deforming)");
}

bool synth_preset_drawn(const std::string& name) { return name == "family" || name == "deforming"; }

SynthPreset synth_preset(const std::string& name) {
  check_synth_preset(name);
  if (synth_preset_drawn(name))
    throw Error("synthetic preset '" + name + "' draws its size from the seed: use synth_scene");
  SynthPreset p;
  p.name = name;
  if (name == "tiny") {
    p.width = 64;
    p.height = 48;
    p.frames = 10;
  } else {  // "default"
    p.width = 160;
    p.height = 120;
    p.frames = 24;
  }
  p.focal = 1.1 * p.width;  // about 49 degrees horizontal field of view
  return p;
}

const char* synth_texture_name(SynthTextureKind kind) {
  switch (kind) {
    case SynthTextureKind::stripes: return "stripes";
    case SynthTextureKind::checks: return "checks";
    case SynthTextureKind::noise: return "noise";
    case SynthTextureKind::gradient: return "gradient";
    case SynthTextureKind::legacy_wall: return "legacy-wall";
    case SynthTextureKind::legacy_floor: return "legacy-floor";
    case SynthTextureKind::legacy_prop_sphere: return "legacy-prop-sphere";
    case SynthTextureKind::legacy_striped_sphere: return "legacy-striped-sphere";
    case SynthTextureKind::legacy_checkered_box: return "legacy-checkered-box";
  }
  return "?";
}

const char* synth_camera_name(SynthCameraKind kind) {
  switch (kind) {
    case SynthCameraKind::legacy_slide: return "slide (fixed world)";
    case SynthCameraKind::slide: return "slide";
    case SynthCameraKind::arc: return "arc";
    case SynthCameraKind::rig: return "rig";
  }
  return "?";
}

SynthScene synth_scene(const std::string& preset, uint32_t seed) {
  if (preset == "family") return draw_family_scene(seed);
  if (preset == "deforming") return draw_deforming_scene(seed);
  return fixed_scene(preset, seed);
}

SynthWorld::SynthWorld(const std::string& preset, uint32_t seed)
    : SynthWorld(synth_scene(preset, seed)) {}

SynthWorld::SynthWorld(SynthScene scene) : scene_(std::move(scene)) {
  if (int(scene_.camera.positions.size()) != scene_.preset.frames)
    throw Error("synthetic scene: " + std::to_string(scene_.camera.positions.size()) +
                " camera positions for " + std::to_string(scene_.preset.frames) + " frames");
}

Camera SynthWorld::camera(int frame) const {
  if (frame < 0 || frame >= preset().frames)
    throw Error("synthetic frame " + std::to_string(frame) + " does not exist");
  return look_at(preset(), scene_.camera.positions[size_t(frame)], scene_.camera.target);
}

Camera SynthWorld::heldout_camera(int index) const {
  const auto& h = scene_.camera.heldout;
  if (index < 1 || index > int(h.size()))
    throw Error("held-out camera " + std::to_string(index) + " does not exist (1 to " +
                std::to_string(h.size()) + ")");
  return look_at(preset(), h[size_t(index - 1)], scene_.camera.target);
}

namespace {

// Object k's motion (1..K), or an error naming the missing object.
const SynthMotion& object_motion(const SynthScene& scene, int object) {
  const int count = static_cast<int>(scene.objects.size());
  if (object < 1 || object > count)
    throw Error("synthetic object " + std::to_string(object) + " does not exist (1 to " + std::to_string(count) + ")");
  return scene.objects[size_t(object - 1)].motion;
}

}  // namespace

Pose34 SynthWorld::object_pose(int object, double time) const {
  const SynthMotion& m = object_motion(scene_, object);
  const double u = 0.5 * (time + 1.0);
  return axis_angle_pose(m.spin_axis, m.spin_rate * u + 2 * kPi * m.spin_phase, motion_centre(m, u));
}

SynthVec SynthWorld::object_stretch(int object, double time) const {
  const SynthMotion& m = object_motion(scene_, object);
  const double u = 0.5 * (time + 1.0);
  const double wave = std::sin(2 * kPi * (m.stretch_rate * u + m.stretch_phase));
  return {1 + m.stretch[0] * wave, 1 + m.stretch[1] * wave, 1 + m.stretch[2] * wave};
}

SynthRender SynthWorld::render(const Camera& camera, double time) const {
  std::vector<SynthInstance> inst;
  for (int k = 1; k <= objects(); ++k) inst.push_back({k, object_pose(k, time), object_stretch(k, time)});
  return render_instances(camera, true, inst);
}

SynthRender SynthWorld::render_instances(const Camera& cam, bool background,
                                         const std::vector<SynthInstance>& instances) const {
  const SynthBackground& bg = scene_.background;
  for (const auto& inst : instances)
    if (inst.object < 1 || inst.object > objects())
      throw Error("synthetic object " + std::to_string(inst.object) + " does not exist");
  SynthRender out;
  out.rgb = Image8(cam.width, cam.height, 3);
  for (int k = 0; k <= objects(); ++k) out.masks.emplace_back(cam.width, cam.height, 1);
  out.depth.width = cam.width;
  out.depth.height = cam.height;
  out.depth.data.assign(size_t(cam.width) * cam.height, 0.0f);
  const V3 o{cam.c2w[3], cam.c2w[7], cam.c2w[11]};

  for (int j = 0; j < cam.height; ++j) {
    for (int i = 0; i < cam.width; ++i) {
      // camera.hpp: direction ((i - cx) / fx, -(j - cy) / fy, -1); t is then the z-depth.
      const V3 dc{(i - cam.cx) / cam.fx, -(j - cam.cy) / cam.fy, -1.0};
      const V3 d{cam.c2w[0] * dc[0] + cam.c2w[1] * dc[1] + cam.c2w[2] * dc[2],
                 cam.c2w[4] * dc[0] + cam.c2w[5] * dc[1] + cam.c2w[6] * dc[2],
                 cam.c2w[8] * dc[0] + cam.c2w[9] * dc[1] + cam.c2w[10] * dc[2]};
      double best = 1e300;
      int owner = -1;  // 0 background, k object
      V3 colour{0, 0, 0};

      if (background) {
        // The wall (facing +z at wall_z) and the floor (facing +y at floor_y), seen from the
        // side their normal points to.
        const auto plane = [&](int axis, double at, const auto& material, const V3& normal) {
          if (!(d[axis] < 0)) return;
          const double t = (at - o[axis]) / d[axis];
          if (t > 1e-9 && t < best) {
            best = t;
            owner = 0;
            colour = mul(albedo(material, add(o, mul(d, t)), normal, 1), shade(normal));
          }
        };
        plane(2, bg.wall_z, bg.wall, {0, 0, 1});
        plane(1, bg.floor_y, bg.floor, {0, 1, 0});
        // Props are axis-aligned: traced about their centre in world axes, the normal taken
        // at the world hit point minus the centre.
        for (const SynthProp& prop : bg.props) {
          const ShapeHit h = intersect_shape(prop.shape, sub(o, prop.centre), d);
          if (h.t > 0 && h.t < best) {
            const V3 p = sub(add(o, mul(d, h.t)), prop.centre);
            const V3 n = shape_normal(prop.shape, p, h.part);
            best = h.t;
            owner = 0;
            colour = mul(albedo(prop.texture, p, n, prop.shape.size[0]), shade(n));
          }
        }
      }

      for (const auto& inst : instances) {
        const SynthObject& obj = scene_.objects[size_t(inst.object - 1)];
        // A stretched shape is the drawn one in axes scaled by 1 / stretch: the ray is mapped
        // there (an affine map keeps its parameter t), the texture stays on the material and
        // the normal takes the inverse transpose, diag(1 / stretch).
        const V3 s = inst.stretch;
        const bool stretched = s[0] != 1 || s[1] != 1 || s[2] != 1;
        V3 ol = to_local_point(inst.pose, o), dl = to_local_dir(inst.pose, d);
        if (stretched) {
          ol = {ol[0] / s[0], ol[1] / s[1], ol[2] / s[2]};
          dl = {dl[0] / s[0], dl[1] / s[1], dl[2] / s[2]};
        }
        const ShapeHit h = intersect_shape(obj.shape, ol, dl);
        if (h.t > 0 && h.t < best) {
          const V3 p = add(ol, mul(dl, h.t));
          const V3 nl = shape_normal(obj.shape, p, h.part);
          const V3 ns = stretched ? normalize({nl[0] / s[0], nl[1] / s[1], nl[2] / s[2]}) : nl;
          best = h.t;
          owner = inst.object;
          colour = mul(albedo(obj.texture, p, nl, obj.shape.size[0]), shade(to_world_dir(inst.pose, ns)));
        }
      }

      if (owner < 0) continue;  // nothing hit: black, depth 0, no mask
      for (int c = 0; c < 3; ++c) out.rgb.at(i, j, c) = to8(colour[c]);
      out.masks[size_t(owner)].at(i, j) = 255;
      out.depth.data[size_t(j) * cam.width + i] = static_cast<float>(best);
    }
  }
  return out;
}

}  // namespace nova

#pragma once
// Synthetic NOVA scenes with exact ground truth: an analytic world ray-traced with the
// camera convention of camera.hpp (one ray per pixel, through pixel (i, j) exactly, no
// anti-aliasing), so a perfect NeRF could reproduce every image.
//
// A world is a SynthScene: a background (a back wall z = wall_z, a floor y = floor_y and a
// few static props), K moving objects (shape, procedural texture, motion along a curve plus a
// spin), a camera path and the imperfections of the training inputs. Presets fill it:
// - "tiny" (tests: 10 frames at 64x48) and "default" (the demo: 24 frames at 160x120): one
//   fixed world (wall z = -6, floor y = -1.4, a static sphere; object 1 a striped sphere,
//   object 2 a checkered box; a monocular camera sliding a little while it looks at the
//   wall). The seed varies textures, motion phases and camera jitter only. Clean inputs.
// - "family": the seed draws a whole scene, to benchmark over many different scenes.
//   * size: 12-16 frames at one of 128x96, 160x90, 160x120, 176x99, 144x108, 192x108;
//     horizontal field of view 45-65 degrees.
//   * background: wall 4.5-8 in front of the camera, floor 1-1.8 below it, 1-3 static props
//     (sphere, box, cylinder) near the wall, each with its own texture.
//   * objects: 1-3, each a sphere, box, cylinder, torus, disc (thin plate), rod (thin
//     cylinder), dumbbell or L (two boxes; both non-convex), 12-30 % of the frame wide at
//     its depth, textured with stripes, checks, sine noise or a gradient in distinct colours.
//     Each moves along a quadratic Bezier curve or a line plus a sinusoid across the view
//     while it spins about a random axis. Objects sit at distinct depths (between 0.25 and
//     0.85 of the wall's) and cross the view in opposite directions, so they pass behind one
//     another; some paths leave the frame partly.
//   * camera: a lateral slide, an arc around a point in the scene, or a rig of 4-8 fixed
//     cameras on a line or an arc, a baseline apart, visited in turn (frame i uses rig
//     camera i mod C, as the NVIDIA Dynamic Scenes monocular videos). Camera 0 is frame 0's.
//     Every camera looks roughly along -z at the wall (forward-facing, as NDC needs).
//   * imperfect training inputs, as real data (ground truth stays exact): masks eroded or
//     dilated by 1-3 px and/or with jagged borders; disparity right only up to an affine map
//     (scale, shift) and blurred (Gaussian), as from a monocular depth network; a per-frame
//     exposure gain of a few percent. Which apply is drawn too; about a quarter are clean.
// - "deforming": the family's scene of the same seed, whose objects also change shape: each
//   squashes and stretches along one of its own axes (by 25-45 %, the other two axes the
//   opposite way by half as much, 0.75-1.5 cycles over the video), as a bouncing ball or a
//   breathing balloon does. Drawn from a stream of its own, so every other draw, and every
//   frame without the objects, is the family scene's: the two measure what a change of
//   shape costs a model.
//
// `nova synth --out DIR` writes the NOVA layout:
//   images/NNN.png, poses_bounds.npy (N x 17, float64), motion_masks/{0..K}/NNN.png,
//   disp/NNN.npy (float32 inverse z-depth), synth.txt (preset, seed, sizes; for the family
//   also the drawn scene in words), and gt/views.txt + gt/poses_bounds.npy + gt/cam0/NNN.png
//   (camera 0 at every time) + gt/heldout{1,2}/NNN.png (held-out cameras at every time), and
//   gt/compose/spec.txt (a compose spec, see compose_spec_text.hpp, in the processed scene frame)
//   + one PNG per target, rendered from that very spec after parsing it back.
// The same preset and seed give byte-identical files.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "nova/data/llff_poses.hpp"
#include "nova/model/scene.hpp"

namespace nova {

using SynthVec = std::array<double, 3>;

struct SynthPreset {
  std::string name;
  int width = 0, height = 0, frames = 0;
  double focal = 0;
  int heldout_cameras = 2;
};

// "tiny" or "default" (fixed sizes); "family" and "deforming" draw their size from the seed
// (SynthScene).
SynthPreset synth_preset(const std::string& name);
// Throws the error an unknown preset name gets; "tiny", "default", "family" and "deforming"
// pass.
// Whether the seed draws the whole scene ("family", "deforming"), so that synth.txt describes it.
bool synth_preset_drawn(const std::string& name);
void check_synth_preset(const std::string& name);

// A shape in its own frame, centred at the origin. `size` per kind:
//   sphere: radius | box: half extents x, y, z | cylinder, disc, rod: radius, half height
//   (axis y) | torus: major radius, minor radius (axis y) | dumbbell: ball radius, ball
//   centre offset along x, bar radius | ell: half length along x, half height along y, half
//   thickness of the two bars (corner at -x, -y).
enum class SynthShapeKind { sphere, box, cylinder, torus, disc, rod, dumbbell, ell };
struct SynthShape {
  SynthShapeKind kind = SynthShapeKind::sphere;
  SynthVec size{0.5, 0.5, 0.5};
};
const char* synth_shape_name(SynthShapeKind kind);
double synth_bounding_radius(const SynthShape& shape);

// Nearest hit t > 0 of the ray o + t d with the shape (d need not be unit length), or -1.
double synth_intersect(const SynthShape& shape, const SynthVec& o, const SynthVec& d);

// The legacy_* kinds are the fixed world's own patterns (kept bit for bit); the others mix
// colour_a and colour_b by a pattern of the surface point (shape frame): `frequency` cycles
// per unit along `direction`, shifted by phase[0..2].
enum class SynthTextureKind {
  stripes, checks, noise, gradient,
  legacy_wall, legacy_floor, legacy_prop_sphere, legacy_striped_sphere, legacy_checkered_box
};
struct SynthTexture {
  SynthTextureKind kind = SynthTextureKind::stripes;
  SynthVec colour_a{0.5, 0.5, 0.5}, colour_b{0.8, 0.8, 0.8};
  double frequency = 1;
  SynthVec direction{1, 0, 0};
  std::array<double, 6> phase{};
};
const char* synth_texture_name(SynthTextureKind kind);

// Object-to-world pose over normalised time u = (t + 1) / 2 in [0, 1): the centre follows
// the curve, the rotation is spin_rate * u + 2 pi spin_phase about spin_axis.
//   bezier: quadratic Bezier with control points p0, p1, p2.
//   sinusoid: p0 + u (p2 - p0) + p1 sin(2 pi (frequency u + phase)).
//   legacy_object1/2: the fixed world's paths (phase[0..1] are its seeded offsets).
enum class SynthMotionKind { bezier, sinusoid, legacy_object1, legacy_object2 };
struct SynthMotion {
  SynthMotionKind kind = SynthMotionKind::bezier;
  SynthVec p0{}, p1{}, p2{};
  double frequency = 0;
  std::array<double, 2> phase{};
  SynthVec spin_axis{0, 1, 0};
  double spin_rate = 0, spin_phase = 0;
  // A change of shape ("deforming"): the shape's own axes scaled by 1 + stretch[a] sin(2 pi
  // (stretch_rate u + stretch_phase)) before the pose (all 0: rigid).
  SynthVec stretch{};
  double stretch_rate = 0, stretch_phase = 0;
};

struct SynthObject {
  SynthShape shape;
  SynthTexture texture;
  SynthMotion motion;
};

// A static prop: axis-aligned, traced in world coordinates about its centre.
struct SynthProp {
  SynthShape shape;
  SynthVec centre{};
  SynthTexture texture;
};

struct SynthBackground {
  double wall_z = -6, floor_y = -1.4;
  SynthTexture wall, floor;
  std::vector<SynthProp> props;
};

// Camera centres per training frame and per held-out camera; every camera looks at `target`
// with world y up. `kind` names the path (legacy_slide: the fixed world's).
enum class SynthCameraKind { legacy_slide, slide, arc, rig };
struct SynthCameraPath {
  SynthCameraKind kind = SynthCameraKind::slide;
  std::vector<SynthVec> positions;  // one per training frame
  std::vector<SynthVec> heldout;    // held-out cameras 1, 2, ...
  SynthVec target{0, 0, -5};
  int rig_cameras = 0;              // rig: C (frame i uses rig camera i mod C)
  bool rig_on_arc = false;
};
const char* synth_camera_name(SynthCameraKind kind);

// Imperfections of the training inputs (images, motion_masks, disp); ground truth is exact.
struct SynthImperfections {
  int mask_grow = 0;          // px: > 0 dilates, < 0 erodes the object masks
  bool mask_jagged = false;   // border pixels of the object masks flip at random
  bool disparity = false;     // disp = scale * gaussian_blur(exact, sigma) + shift
  double disp_scale = 1, disp_shift = 0, disp_sigma = 0;
  std::vector<double> gains;  // per-frame exposure gains (empty: none)
  uint32_t noise_seed = 0;    // for the jagged borders
  bool any() const { return mask_grow != 0 || mask_jagged || disparity || !gains.empty(); }
};

struct SynthScene {
  SynthPreset preset;
  uint32_t seed = 0;
  SynthBackground background;
  std::vector<SynthObject> objects;  // object k is objects[k - 1]
  SynthCameraPath camera;
  SynthImperfections imperfections;
  // Raw-world offsets used by the composition targets (object 1 moved, its second copy).
  SynthVec compose_shift{0.5, 0.35, 0}, compose_copy_shift{0, 0.45, 0.3};
};

// The scene of a preset and seed ("tiny", "default", "family" or "deforming").
SynthScene synth_scene(const std::string& preset, uint32_t seed);
// The family's sampler (synth_family.cpp).
SynthScene draw_family_scene(uint32_t seed);
// The family's scene of `seed` with objects that change shape (the "deforming" preset).
SynthScene draw_deforming_scene(uint32_t seed);
// The scene in words: shapes, textures, motions, camera path, size, imperfections.
std::string describe_synth_scene(const SynthScene& scene);

// The training-input imperfections (synth_imperfect.cpp); identities when none apply.
std::vector<Image8> synth_training_masks(const std::vector<Image8>& exact,
                                         const SynthImperfections& imp, int frame);
ImageF synth_training_disparity(const ImageF& exact, const SynthImperfections& imp);
Image8 synth_training_image(const Image8& exact, const SynthImperfections& imp, int frame);

// One render: colour, masks (1 + K: 0 = background, k = object k; 255 where it is the first
// surface hit) and z-depth along the camera's -z axis.
struct SynthRender {
  Image8 rgb;
  std::vector<Image8> masks;
  ImageF depth;
};

// An object instance to draw: object k (1..K) with an object-to-world pose, its shape's own
// axes scaled by `stretch` first (SynthWorld::object_stretch; 1, 1, 1: as drawn).
struct SynthInstance {
  int object = 1;
  Pose34 pose{};
  SynthVec stretch{1, 1, 1};
};

class SynthWorld {
 public:
  SynthWorld(const std::string& preset, uint32_t seed);
  explicit SynthWorld(SynthScene scene);

  const SynthPreset& preset() const { return scene_.preset; }
  const SynthScene& scene() const { return scene_; }
  int objects() const { return int(scene_.objects.size()); }  // K
  Camera camera(int frame) const;         // training camera of frame i (raw world)
  Camera heldout_camera(int index) const; // 1..heldout_cameras
  Pose34 object_pose(int object, double time) const;  // object-to-world at time t
  SynthVec object_stretch(int object, double time) const;  // its shape's axis scales at time t

  // The scene at time t as the camera sees it.
  SynthRender render(const Camera& camera, double time) const;
  // The background (when `background`) plus the given instances.
  SynthRender render_instances(const Camera& camera, bool background,
                               const std::vector<SynthInstance>& instances) const;

 private:
  SynthScene scene_;
};

// Writes the scene into `out_dir` (staged in a temporary sibling, renamed at the end; an
// existing `out_dir` is an error unless `replace`). Returns a short report.
std::string write_synthetic_scene(const std::string& out_dir, const std::string& preset,
                                  uint32_t seed, bool replace = false);

}  // namespace nova

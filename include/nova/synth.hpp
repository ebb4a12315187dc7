#pragma once
// Synthetic NOVA scenes with exact ground truth: an analytic world ray-traced with the
// camera convention of camera.hpp (one ray per pixel, through pixel (i, j) exactly, no
// anti-aliasing), so a perfect NeRF could reproduce every image.
//
// The world (raw coordinates, OpenGL axes, metres-ish): a textured back wall (z = -6), a
// floor (y = -1.4) and a static sphere give the background depth variation; object 1 is a
// striped sphere and object 2 a checkered box, both moving and spinning over time. A
// monocular camera translates a little from frame to frame while looking at the wall. The
// seed varies textures (colours, phases), motion phases and camera jitter.
//
// `nova synth --out DIR` writes the NOVA layout:
//   images/NNN.png, poses_bounds.npy (N x 17, float64), motion_masks/{0,1,2}/NNN.png,
//   disp/NNN.npy (float32 inverse z-depth), synth.txt (preset, seed, sizes), and
//   gt/views.txt + gt/poses_bounds.npy + gt/cam0/NNN.png (camera 0 at every time) +
//   gt/heldout{1,2}/NNN.png (held-out cameras at every time), and gt/compose/spec.txt
//   (a compose spec, see compose_spec.hpp, in the processed scene frame) + one PNG per
//   target, rendered from that very spec after parsing it back.
// The same preset and seed give byte-identical files.
#include <cstdint>
#include <string>
#include <vector>

#include "nova/llff_poses.hpp"
#include "nova/scene.hpp"

namespace nova {

struct SynthPreset {
  std::string name;
  int width = 0, height = 0, frames = 0;
  double focal = 0;
  int heldout_cameras = 2;
};

// "tiny" (tests: 10 frames at 64x48) or "default" (the demo: 24 frames at 160x120).
SynthPreset synth_preset(const std::string& name);

// One render: colour, masks (1 + K: 0 = background, k = object k; 255 where it is the first
// surface hit) and z-depth along the camera's -z axis.
struct SynthRender {
  Image8 rgb;
  std::vector<Image8> masks;
  ImageF depth;
};

// An object instance to draw: object k (1..K) with an object-to-world pose.
struct SynthInstance {
  int object = 1;
  Pose34 pose{};
};

class SynthWorld {
 public:
  static constexpr int kObjects = 2;

  SynthWorld(const std::string& preset, uint32_t seed);

  const SynthPreset& preset() const { return preset_; }
  Camera camera(int frame) const;         // training camera of frame i (raw world)
  Camera heldout_camera(int index) const; // 1..heldout_cameras
  Pose34 object_pose(int object, double time) const;  // object-to-world at time t

  // The scene at time t as the camera sees it.
  SynthRender render(const Camera& camera, double time) const;
  // The background (when `background`) plus the given instances.
  SynthRender render_instances(const Camera& camera, bool background,
                               const std::vector<SynthInstance>& instances) const;

 private:
  SynthPreset preset_;
  double rnd_[32] = {};  // seeded parameters in [0, 1)
};

// Writes the scene into `out_dir` (staged in a temporary sibling, renamed at the end; an
// existing `out_dir` is an error unless `replace`). Returns a short report.
std::string write_synthetic_scene(const std::string& out_dir, const std::string& preset,
                                  uint32_t seed, bool replace = false);

}  // namespace nova

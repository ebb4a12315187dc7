#pragma once
// A scene in memory: what every reader produces and what the trainer consumes. Plain data
// only (no OpenCV), so the core library and an HPC job can use it.
//
// Conventions (shared with camera.hpp):
// - Images are 8-bit, row-major, interleaved, RGB order (not OpenCV's BGR), row 0 at the top.
// - Masks are 8-bit single-channel: 255 = inside, 0 = outside; warped masks may hold
//   fractional values in between.
// - NeRF 0 is the static background, NeRFs 1..K are the objects; Frame::masks has 1 + K
//   entries. A static-only scene has K = 0 and one all-255 background mask per frame.
// - Frame i of N has time t = 2 i / N - 1 (the reference code's convention, so t lies in
//   [-1, 1 - 2/N]); Blender/D-NeRF `time` values in [0, 1] are mapped to 2 time - 1.
// - Cameras are in the scene's processed world coordinates: for LLFF/NOVA data after the
//   reference's rescaling (1 / (5th-percentile near bound * bd_factor)) and recentring, so
//   poses, bounds, ground truth and composition specs all share one frame.
#include <cstdint>
#include <string>
#include <vector>

#include "nova/sampling/camera.hpp"
#include "nova/model/compose_spec.hpp"

namespace nova {

struct Image8 {
  int width = 0, height = 0, channels = 0;
  std::vector<uint8_t> data;  // height * width * channels

  Image8() = default;
  Image8(int w, int h, int c, uint8_t fill = 0)
      : width(w), height(h), channels(c), data(size_t(w) * h * c, fill) {}
  bool empty() const { return data.empty(); }
  uint8_t& at(int x, int y, int c = 0) { return data[(size_t(y) * width + x) * channels + c]; }
  uint8_t at(int x, int y, int c = 0) const {
    return data[(size_t(y) * width + x) * channels + c];
  }
};

struct ImageF {
  int width = 0, height = 0;
  std::vector<float> data;  // height * width, row-major
  bool empty() const { return data.empty(); }
};

struct Frame {
  std::string name;        // source file name, e.g. "000.png"
  Image8 rgb;              // 3 channels
  Camera camera;
  double time = 0;         // see the header comment
  double near = 0, far = 0;  // this frame's depth bounds after processing (0 when unknown)
  std::vector<Image8> masks;  // 1 + K single-channel masks
  ImageF disparity;        // optional (empty when the scene has none), resized to the image
};

// A held-out view with known ground truth (synthetic scenes, or datasets that ship one).
struct GroundTruthView {
  std::string name;    // file name relative to the scene's gt/ folder
  std::string kind;    // "cam0" (camera 0 at every time, the paper's protocol) or "heldout"
  int time_index = 0;  // the training frame whose time this view shows
  double time = 0;
  Camera camera;
  Image8 rgb;
  // The view's index among the scene folder's own frames when it is one of them (a frame a
  // --holdout run kept out of training), else -1 (a ground-truth camera beside the frames,
  // such as a synthetic scene's held-out cameras).
  int folder_index = -1;
  // Where the objects are in this view: one channel, the largest of the objects' masks (>= 128
  // counts as object), as the training rays' regions are drawn; empty when the view's masks
  // are unknown. nova eval scores the objects and the background apart with it.
  Image8 objects;
};

// A composition target: the background plus object instances placed as the spec says.
struct ComposeTargetImage {
  std::string name;  // ComposeTarget::name
  Image8 rgb;
  Image8 objects;    // where its instances are (>= 128), when the truth gives it; else empty
};

struct Scene {
  std::string name;     // folder name
  std::string format;   // "nova", "dynamicnerf", "llff", "blender"
  std::string source;   // folder it was read from
  int num_objects = 0;  // K
  bool ndc = false;     // forward-facing: rays in NDC with the near plane at 1
  bool has_time = true; // false for static datasets (LLFF, Blender without `time`)
  double near = 0, far = 0;  // scene bounds after processing (min / max over frames)
  double bd_factor = 0;      // the bound factor used in processing (0 when none)
  std::vector<Frame> frames;
  std::vector<GroundTruthView> gt_views;
  ComposeSpec compose;                         // empty when the scene has none
  std::vector<ComposeTargetImage> compose_gt;  // ground-truth images of compose targets
  std::vector<std::string> notes;  // what the reader found, did or assumed, one line each

  int num_nerfs() const { return 1 + num_objects; }
};

inline double frame_time(int i, int n) { return n > 0 ? 2.0 * i / n - 1.0 : 0.0; }

}  // namespace nova

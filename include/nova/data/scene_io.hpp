#pragma once
// Scene readers: every supported layout into one nova::Scene. Errors (missing or extra
// frames, mask counts, bad .npy, unreadable PNGs, non-finite poses, bad bounds) throw
// nova::Error naming the file and the problem.
//
// Layouts:
// - "nova" (NOVA / DynamicNeRF): images/ (or images_F/), poses_bounds.npy (N x 17),
//   motion_masks/ as numbered folders 0..K (0 = background) or one folder of PNGs holding the
//   moving region (DynamicNeRF: K = 1, background = its complement), optional disp/*.npy,
//   optional gt/ (written by `nova synth`: views.txt + poses_bounds.npy + images, and
//   compose/spec.txt + target images). Processed with bd_factor 0.9, recentred, NDC.
// - "llff": images/ (or images_F/) + poses_bounds.npy, no masks: static-only (K = 0),
//   bd_factor 0.75, recentred, NDC.
// - "blender": transforms_<split>.json (Blender / D-NeRF; `time` per frame where present),
//   RGBA composited on white, near 2, far 6, no NDC, K = 0.
// - "npz": a folder holding one D-NeRF-style .npz (or the .npz itself); see
//   load_dnerf_npz_scene.
#include <string>

#include "nova/model/scene.hpp"

namespace nova {

struct LoadOptions {
  std::string format = "auto";  // auto | nova | llff | blender | npz
  int factor = 0;               // image downscale factor; 0 = auto (images/ if present, else
                                // the one images_F/ folder; Blender: 1)
  bool static_only = false;     // load a NOVA scene without masks as static-only (K = 0)
  std::string split = "train";  // Blender: which transforms_<split>.json
  bool load_gt = true;          // read gt/ when present
  bool white_background = true; // Blender: composite RGBA on white
};

// Detects the layout ("nova" when poses_bounds.npy has motion_masks/ or disp/ beside it,
// "llff" for poses_bounds.npy alone, "blender" for transforms_<split>.json).
std::string detect_format(const std::string& dir, const LoadOptions& opt = {});

Scene load_scene(const std::string& dir, const LoadOptions& opt = {});
Scene load_nova_scene(const std::string& dir, const LoadOptions& opt = {});
Scene load_llff_scene(const std::string& dir, const LoadOptions& opt = {});
Scene load_blender_scene(const std::string& dir, const LoadOptions& opt = {});
// The "tiny D-NeRF" .npz (images, poses, times, focal; splits found from time resets).
Scene load_dnerf_npz_scene(const std::string& dir_or_file, const LoadOptions& opt = {});

// A few lines describing the scene: sizes, cameras, masks, bounds, ground truth, notes.
std::string scene_summary(const Scene& scene);

// Moves frames 0, n, 2n, ... of `scene` out of training into its ground-truth views (kind
// "heldout", named frame_III), the LLFF evaluation protocol; Error when fewer than 2 frames.
void hold_out_frames(Scene& scene, int every);

// Where a view's objects are, from its 1 + K masks: the largest object mask per pixel (one
// channel; >= 128 is object), as training draws its regions; empty without object masks.
Image8 objects_region(const std::vector<Image8>& masks);

// The file beside a ground-truth image that holds its objects region (optional; nova synth
// writes it; any non-zero pixel is object): "cam0/000.png" -> "cam0/000_objects.png".
std::string ground_truth_objects_name(const std::string& image);

}  // namespace nova

#pragma once
// Motion masks from the video itself: what moves, found from the frames, the camera poses and
// the disparity maps alone (no optical flow, no network). `nova masks` runs it.
//
// 1. Depth: each frame's disparity d becomes inverse depth w = a d + b, with (a, b) from
//    nova's fit_disparity (disparity_fit.hpp) on all pixels: textured pixels of every frame
//    placed at that depth and seen from the neighbouring frames' cameras match in colour (a
//    truncated error, so moving pixels do not pull the fit). A global fit, then per frame a
//    local one where `per_frame_fit` (monocular depth networks scale each frame their own way).
// 2. Score: every pixel, placed at its depth, is reprojected into the neighbouring frames. A
//    neighbour that sees something nearer there (an occlusion) says nothing; the others score
//    the colour mismatch (the best within `match_radius` pixels) and how far the neighbour
//    sees behind the point (a static point
//    cannot vanish). The score of a pixel is the mean of its lower half of those scores, so
//    one neighbour's occlusion or glare does not look like motion.
// 3. Masks: the score, smoothed, above a threshold taken from its own distribution (a robust
//    noise level, never below an absolute floor), cleaned (small regions dropped, holes filled
//    unless their depth lies behind the region: background seen through the object), peeled
//    (a pixel that is motion at its depth but matches at the background's depth beside the
//    region is background under a disparity blurred towards the object), grown
//    over the depth's smooth surfaces where that stays bounded (the parts of a moving object
//    that hardly move) and its edges moved to the image's colour edges (OpenCV's GrabCut, which
//    may not add pixels behind the region).
// 4. Objects: connected regions, tracked through time by overlap; a track is an object where
//    it is seen in enough frames. --objects K merges the smaller tracks into the nearest of
//    the K largest.
#include <functional>
#include <string>
#include <vector>

#include "nova/model/scene.hpp"

namespace nova {

struct MotionMaskOptions {
  int objects = 0;                       // K; 0: as many as are found
  std::vector<int> offsets{1, 2, 3, 4};  // neighbours of frame i: i - o and i + o
  bool per_frame_fit = true;             // refine the depth's scale and shift per frame
  double colour_scale = 0.08;            // mean absolute colour error (0..1) that scores 1
  int match_radius = 0;                  // colour matched within this many pixels of the landing
                                         // point; 0: one per 240 px of width (at least 1)
  double depth_scale = 0.10;             // relative inverse-depth deficit that scores 1
  double occlusion_margin = 0.05;        // relative: a neighbour nearer by more occludes
  double depth_search = 0.1;             // relative: inverse depths tried around the fitted one
  int depth_search_steps = 3;            // on either side
  double threshold_floor = 0.5;          // the threshold is never below this score
  double threshold_mads = 6.0;           // robust noise level: median + this many MAD sigmas
  double grow_depth = 0.005;             // relative inverse-depth step the region grows over (0: off)
  double grow_limit = 6.0;               // a part that would add more than this many times its
                                         // area (or a quarter of the frame) does not grow
  double peel_radius = 0.03;             // fraction of the width: a region's pixels that are motion
                                         // at their depth but match at the farthest depth this near
                                         // outside the region are background (0: off)
  double min_area = 0.002;               // regions smaller than this fraction of a frame drop
  double min_track_frames = 0.15;        // a track is an object in this fraction of frames (and 2)
  bool grabcut = true;                   // refine edges on the image
  double grabcut_band = 0.11;            // GrabCut works this far around the region (fraction of
                                         // the frame's smaller side)
  std::function<void(const std::string&)> progress;  // one line per stage (may be empty)
};

// The fitted depth: inverse depth = scale[i] * disparity + shift[i] for frame i (processed
// scene units, 1 / z along the camera's view axis).
struct DepthFit {
  std::vector<double> scale, shift;
  double global_scale = 0, global_shift = 0;
  double cost = 0;  // mean truncated colour error of the global fit's samples
  bool parallax = false;  // the fit beats every constant depth (DisparityFit::ok)
};

struct MotionMasks {
  std::vector<std::vector<Image8>> masks;  // [nerf][frame]: 0 background, 1..K objects; 255 in
  std::vector<ImageF> scores;              // per frame, the smoothed score
  DepthFit depth;
  double threshold = 0;
  bool nothing_moves = false;              // no region moved: masks = all background + one empty object
  std::vector<std::string> notes;          // what was found and decided, one line each
  int objects() const { return int(masks.size()) - 1; }
};

// The masks of `scene` (a NOVA scene loaded with its disparity; existing masks are ignored).
// Error when the scene has no disparity or fewer than 2 frames.
MotionMasks make_motion_masks(const Scene& scene, const MotionMaskOptions& options = {});

// Writes `masks` as a motion_masks folder: 0/ .. K/ (NNN.png, NNN the frame index), check/NNN.png
// (frame, score, masks side by side) and masks.txt (the notes). Staged in a temporary sibling
// and renamed at the end, so a failure leaves nothing; an existing `out_dir` is an error unless
// `replace`.
void write_motion_masks(const Scene& scene, const MotionMasks& masks, const std::string& out_dir,
                        bool replace = false);

// Intersection over union of two masks' non-zero pixels (1 when both are empty).
double mask_iou(const Image8& a, const Image8& b);
// The union of masks 1..K of one frame (255 where any object is).
Image8 objects_union(const std::vector<Image8>& masks_of_frame);

}  // namespace nova

#pragma once
// The scene's disparity placed in depth: a monocular depth network gives disparity up to a
// scale and a shift, and the static background fixes both. Background pixels of every frame
// are placed at the inverse depth w = scale * disparity + shift, projected into neighbouring
// frames (whose cameras are known) and compared there by colour; the (scale, shift) whose
// projections match best wins. It needs no trained NeRF: a NeRF's rendered depth is biased
// where it keeps faint density in front of a surface.
#include <vector>

#include "nova/model/scene.hpp"

namespace nova {

struct DisparityFit {
  bool ok = false;      // a fit that beats every constant depth (the scene has parallax)
  double scale = 0;     // inverse camera-space depth = scale * disparity + shift
  double shift = 0;
  double cost = 0;      // mean truncated colour difference of the projections at the fit
  int samples = 0;      // background pixels compared
  // With DisparityFitOptions::per_frame: each frame's own (scale, shift), refined from the
  // global fit on that frame's samples alone (monocular networks scale every frame their own
  // way); empty otherwise.
  std::vector<double> frame_scale, frame_shift;

  double inverse_depth(double disparity) const { return scale * disparity + shift; }
};

struct DisparityFitOptions {
  int samples_per_frame = 300;        // textured background pixels of each frame
  std::vector<int> neighbours{-4, -2, -1, 1, 2, 4};  // frame offsets each sample is compared in
  double blur_px = 1.0;               // at 160 px width, scaled with the frames
  double truncate = 0.15;             // a colour difference counts at most this much (occlusions)
  bool use_masks = true;              // sample the background (masks[0]) only; false: every pixel
                                      // (no masks yet: the truncation keeps moving pixels' pull small)
  bool per_frame = false;             // also refine a (scale, shift) per frame (frame_scale, frame_shift)
};

DisparityFit fit_disparity(const Scene& scene, const DisparityFitOptions& options = {});

}  // namespace nova

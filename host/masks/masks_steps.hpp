#pragma once
// The steps of make_motion_masks (include/nova/masks/motion_masks.hpp), one file each:
// reprojection.cpp (frames as float images, the pair geometry, the fitted depth), motion_score.cpp,
// segment.cpp (threshold, clean-up, GrabCut) and tracks.cpp (objects through time).
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "nova/masks/motion_masks.hpp"

namespace nova::masks {

// A frame as the steps use it: colour as float (each channel divided by twice its frame mean,
// so a global exposure change cancels), the disparity and, once fitted (nova's fit_disparity),
// the inverse depth.
struct FrameData {
  cv::Mat rgb;       // CV_32FC3
  cv::Mat disp;      // CV_32F
  cv::Mat inv_depth; // CV_32F, after the fit
  Camera camera;
};
std::vector<FrameData> prepare_frames(const Scene& scene);

// Camera a's pixel at inverse depth w, seen from camera b. Precomputed per pair: the rotation
// M = Rb^T Ra and offset T = Rb^T (ta - tb), so that the point in b's frame is
// (M dir + w T) / w with dir = ((x - cx) / fx, -(y - cy) / fy, -1) (camera.hpp's convention).
struct PairGeometry {
  double m[9], t[3];
  double fxa, fya, cxa, cya, fxb, fyb, cxb, cyb;
};
PairGeometry pair_geometry(const Camera& a, const Camera& b);

// Where pixel (x, y) of camera a at inverse depth w > 0 lands in camera b, and its inverse
// depth there; false when it lands behind b.
inline bool reproject(const PairGeometry& g, double x, double y, double w, double& bx, double& by,
                      double& bw) {
  const double dx = (x - g.cxa) / g.fxa, dy = -(y - g.cya) / g.fya, dz = -1.0;
  const double qx = g.m[0] * dx + g.m[1] * dy + g.m[2] * dz + w * g.t[0];
  const double qy = g.m[3] * dx + g.m[4] * dy + g.m[5] * dz + w * g.t[1];
  const double qz = g.m[6] * dx + g.m[7] * dy + g.m[8] * dz + w * g.t[2];
  const double z = -qz;  // depth in b times w
  if (z <= 1e-9) return false;
  bx = g.cxb + g.fxb * qx / z;
  by = g.cyb - g.fyb * qy / z;
  bw = w / z;
  return true;
}

// Bilinear sample of a float image with c channels at (x, y); false outside [0, w-1] x [0, h-1].
bool sample_bilinear(const cv::Mat& image, double x, double y, float* out);

// The neighbours of frame i: i - o and i + o for each offset that stays inside [0, n).
std::vector<int> neighbours(int i, int n, const std::vector<int>& offsets);

// inv_depth of every frame from its disparity and the fit.
void apply_depth(std::vector<FrameData>& frames, const DepthFit& fit);

// The score of frame i's pixels against its neighbours (options.offsets): operator() at a given
// inverse depth (-1 where no neighbour sees the point), best() the lowest over the depths
// searched about the fitted one.
class PixelScorer {
 public:
  PixelScorer(const std::vector<FrameData>& frames, int i, const MotionMaskOptions& options);
  double operator()(int x, int y, double inv_depth) const;
  double best(int x, int y) const;

 private:
  const FrameData& frame_;
  const MotionMaskOptions& options_;
  std::vector<std::pair<const FrameData*, PairGeometry>> views_;
  std::vector<double> factors_;  // of the fitted inverse depth, searched by best()
  int radius_ = 1;
  mutable std::vector<float> per_;
};

// The raw per-pixel motion score of frame i (CV_32F).
cv::Mat motion_score(const std::vector<FrameData>& frames, int i, const MotionMaskOptions& options);
// `region` of frame i without the pixels that are motion at their own depth (raw_score, frame
// i's motion_score, at or above threshold) but match their neighbours when placed at the
// farthest depth outside the region within options.peel_radius (a fraction of the width):
// background whose disparity a blur carried towards the object's.
cv::Mat peel_background(const std::vector<FrameData>& frames, int i, const cv::Mat& region, const cv::Mat& raw_score,
                        double threshold, const MotionMaskOptions& options);

// The threshold from the smoothed scores of all frames.
double score_threshold(const std::vector<cv::Mat>& scores, const MotionMaskOptions& options,
                       std::vector<std::string>& notes);
// The moving region of frame i (CV_8U, 255 inside) from its smoothed and raw scores:
// threshold, clean-up, peel_background, growth over the depth's smooth surfaces
// (options.grow_depth), GrabCut.
cv::Mat moving_region(const cv::Mat& score, const cv::Mat& raw_score, double threshold, const Image8& frame,
                      const std::vector<FrameData>& frames, int i, const MotionMaskOptions& options);
// Each connected part of `region` grown over pixels whose inverse depth changes by less than
// `step` (relative) from pixel to pixel, unless it would grow past `max_growth` times its area.
cv::Mat grow_on_depth(const cv::Mat& region, const cv::Mat& inv_depth, double step, double max_growth);
// The median of `inv_depth` (CV_32F) over the non-zero pixels of `where` (CV_8U); 0 where
// there are none.
float median_inverse_depth(const cv::Mat& where, const cv::Mat& inv_depth);
// Drops connected regions under `min_pixels` and fills enclosed holes (CV_8U, 255 inside); with
// `inv_depth`, not the holes whose depth lies behind the region around them (background seen
// through the object).
cv::Mat clean_region(const cv::Mat& region, int min_pixels, const cv::Mat& inv_depth = cv::Mat());

// Splits the moving regions of all frames into objects tracked through time: [object][frame],
// CV_8U 255 inside; empty when nothing persists. inv_depth: per frame (CV_32F), to tell
// objects apart where their regions touch.
std::vector<std::vector<cv::Mat>> track_objects(const std::vector<cv::Mat>& regions,
                                                const std::vector<cv::Mat>& inv_depth,
                                                const MotionMaskOptions& options,
                                                std::vector<std::string>& notes);

}  // namespace nova::masks

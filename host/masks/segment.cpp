// From scores to moving regions (masks_steps.hpp): the threshold from the scores' own
// distribution, clean-up, and GrabCut to move the edges onto the image's colour edges.
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "masks/masks_steps.hpp"

namespace nova::masks {

double score_threshold(const std::vector<cv::Mat>& scores, const MotionMaskOptions& options,
                       std::vector<std::string>& notes) {
  std::vector<float> all;
  for (const cv::Mat& s : scores) all.insert(all.end(), s.begin<float>(), s.end<float>());
  if (all.empty()) return options.threshold_floor;
  auto median = [](std::vector<float>& v) {
    std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
    return double(v[v.size() / 2]);
  };
  const double m = median(all);
  for (float& v : all) v = float(std::abs(v - m));
  const double sigma = 1.4826 * median(all);  // the MAD as a normal's standard deviation
  const double noise = m + options.threshold_mads * sigma;
  const double t = std::max(options.threshold_floor, noise);
  std::ostringstream s;
  s << "score: median " << m << ", MAD sigma " << sigma << "; threshold " << t
    << (t == options.threshold_floor ? " (the floor)" : " (median + " + std::to_string(int(options.threshold_mads)) + " sigma)");
  notes.push_back(s.str());
  return t;
}

float median_inverse_depth(const cv::Mat& where, const cv::Mat& inv_depth) {
  std::vector<float> v;
  for (int y = 0; y < where.rows; ++y)
    for (int x = 0; x < where.cols; ++x)
      if (where.at<uint8_t>(y, x)) v.push_back(inv_depth.at<float>(y, x));
  if (v.empty()) return 0.0f;
  std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
  return v[v.size() / 2];
}

cv::Mat clean_region(const cv::Mat& region, int min_pixels, const cv::Mat& inv_depth) {
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(region, labels, stats, centroids, 8, CV_32S);
  cv::Mat out(region.size(), CV_8U, cv::Scalar(0));
  for (int k = 1; k < n; ++k)
    if (stats.at<int>(k, cv::CC_STAT_AREA) >= min_pixels) out.setTo(255, labels == k);
  // Holes: background pixels not connected to the image border.
  cv::Mat outside;
  cv::copyMakeBorder(out, outside, 1, 1, 1, 1, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::floodFill(outside, cv::Point(0, 0), cv::Scalar(128));
  const cv::Mat holes = outside(cv::Rect(1, 1, out.cols, out.rows)) == 0;
  if (inv_depth.empty()) {
    out.setTo(255, holes);
    return out;
  }
  // A hole is the inside of a slow or textureless object (its middle lands on itself and
  // matches) unless its depth lies behind the region around it: then it is the background seen
  // through the object (a ring's or a torus' hole, the gap between an arm and the body) and stays
  // open. Behind: its median inverse depth more than 5 % below the median of the region's
  // pixels within 3 px of it.
  cv::Mat hole_labels;
  const int holes_n = cv::connectedComponents(holes, hole_labels, 4, CV_32S);
  const cv::Mat k7 = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(7, 7));
  for (int k = 1; k < holes_n; ++k) {
    const cv::Mat hole = hole_labels == k;
    cv::Mat ring;
    cv::dilate(hole, ring, k7);
    ring &= out;
    if (median_inverse_depth(hole, inv_depth) >= 0.95f * median_inverse_depth(ring, inv_depth)) out.setTo(255, hole);
  }
  return out;
}

cv::Mat grow_on_depth(const cv::Mat& region, const cv::Mat& inv_depth, double step, double max_growth) {
  // Each connected part of the moving region grows over its surfaces (a person's torso that
  // hardly moves under a moving head and arms): to 4-neighbours whose inverse depth differs by
  // less than `step` (relative) and that lie no farther than the part's 10th percentile
  // inverse depth minus 5 %, so that a slow ramp cannot lead onto the background behind, and no
  // nearer than its 90th percentile plus 5 %, so that it cannot run down a floor towards the
  // camera from where the object stands on it. A
  // part that would add more than `max_growth` times its area, or a quarter of the frame,
  // stands on a surface that goes on (a false region on a wall, an object just in front of
  // the wall): it keeps its own pixels only. The 5 % and the quarter were chosen on family
  // dev seeds 1-4 and Balloon1 (with 10 % and half the frame, seed 4's wall is taken).
  cv::Mat labels;
  const int parts = cv::connectedComponents(region, labels, 8, CV_32S);
  cv::Mat out = region.clone();
  const int w = region.cols, h = region.rows;
  for (int k = 1; k < parts; ++k) {
    std::vector<cv::Point> queue;
    std::vector<float> ws;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        if (labels.at<int>(y, x) == k) queue.push_back({x, y}), ws.push_back(inv_depth.at<float>(y, x));
    std::nth_element(ws.begin(), ws.begin() + long(ws.size() / 10), ws.end());
    const float floor_w = ws[ws.size() / 10] * 0.95f;
    std::nth_element(ws.begin(), ws.begin() + long(ws.size() * 9 / 10), ws.end());
    const float ceiling_w = ws[ws.size() * 9 / 10] * 1.05f;
    const size_t limit = std::min(size_t(max_growth * double(queue.size())), region.total() / 4);
    cv::Mat grown(region.size(), CV_8U, cv::Scalar(0));
    std::vector<cv::Point> added;
    while (!queue.empty() && added.size() <= limit) {
      const cv::Point p = queue.back();
      queue.pop_back();
      const float wp = inv_depth.at<float>(p);
      for (const cv::Point d : {cv::Point(1, 0), cv::Point(-1, 0), cv::Point(0, 1), cv::Point(0, -1)}) {
        const cv::Point q = p + d;
        if (q.x < 0 || q.y < 0 || q.x >= w || q.y >= h || region.at<uint8_t>(q) || grown.at<uint8_t>(q)) continue;
        const float wq = inv_depth.at<float>(q);
        if (wq < floor_w || wq > ceiling_w || std::abs(wq - wp) > step * wp) continue;
        grown.at<uint8_t>(q) = 255;
        added.push_back(q);
        queue.push_back(q);
      }
    }
    if (added.size() <= limit) out |= grown;
  }
  return out;
}

cv::Mat moving_region(const cv::Mat& score, const cv::Mat& raw_score, double threshold, const Image8& frame,
                      const std::vector<FrameData>& frames, int i, const MotionMaskOptions& options) {
  const cv::Mat& inv_depth = frames[size_t(i)].inv_depth;
  const int min_pixels = std::max(4, int(options.min_area * score.total()));
  cv::Mat region = score > threshold;
  const cv::Mat k3 = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(3, 3));
  const cv::Mat k5 = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(5, 5));
  cv::morphologyEx(region, region, cv::MORPH_OPEN, k3);
  cv::morphologyEx(region, region, cv::MORPH_CLOSE, k5);
  region = clean_region(region, min_pixels, inv_depth);
  // Before growth and GrabCut, so that both start from the object rather than the band of
  // background a blurred disparity carries around it (a thin rod's region is three times its width).
  region = clean_region(peel_background(frames, i, region, raw_score, threshold, options), min_pixels, inv_depth);
  if (options.grow_depth > 0) region = grow_on_depth(region, inv_depth, options.grow_depth, options.grow_limit);
  if (!options.grabcut || cv::countNonZero(region) == 0) return region;

  // GrabCut inside a band around the region: sure background beyond it, probable background in
  // it, probable foreground in the region, sure foreground where the score is high well inside.
  // The band is wide (options.grabcut_band, 11 % of the smaller side) so that an object's smooth
  // middle between two moving ends (Balloon1's balloon) can join them; docs/masks.md has the
  // measurements the width was chosen by.
  const int band = std::max(6, int(options.grabcut_band * std::min(score.cols, score.rows)));
  cv::Mat near_region;
  cv::dilate(region, near_region, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * band + 1, 2 * band + 1)));
  cv::Mat inner;
  cv::erode(region, inner, k5);
  cv::Mat sure = inner & (score > 2 * threshold);
  cv::Mat gc(score.size(), CV_8U, cv::Scalar(cv::GC_BGD));
  gc.setTo(cv::GC_PR_BGD, near_region);
  gc.setTo(cv::GC_PR_FGD, region);
  gc.setTo(cv::GC_FGD, sure);
  const cv::Rect roi = cv::boundingRect(near_region);
  const cv::Mat bgr = [&] {
    cv::Mat rgb(frame.height, frame.width, CV_8UC3, const_cast<uint8_t*>(frame.data.data())), out;
    cv::cvtColor(rgb, out, cv::COLOR_RGB2BGR);
    return out;
  }();
  cv::Mat gc_roi = gc(roi).clone(), bgd, fgd;
  if (cv::countNonZero(gc_roi == cv::GC_BGD) + cv::countNonZero(gc_roi == cv::GC_PR_BGD) < 16) return region;
  // GrabCut's k-means draws from OpenCV's thread RNG: a fixed state per frame gives the same
  // masks whatever ran before.
  cv::theRNG().state = 0x6e6f7661;
  cv::grabCut(bgr(roi), gc_roi, cv::Rect(), bgd, fgd, 3, cv::GC_INIT_WITH_MASK);
  gc_roi.copyTo(gc(roi));
  cv::Mat out = (gc == cv::GC_FGD) | (gc == cv::GC_PR_FGD);
  {
    // GrabCut goes by colour alone; what it adds must not lie behind the region (background of
    // the object's colours seen around it): not farther than the region's 10th percentile
    // inverse depth minus 5 %, as for the growth.
    std::vector<float> ws;
    for (int y = 0; y < region.rows; ++y)
      for (int x = 0; x < region.cols; ++x)
        if (region.at<uint8_t>(y, x)) ws.push_back(inv_depth.at<float>(y, x));
    std::nth_element(ws.begin(), ws.begin() + long(ws.size() / 10), ws.end());
    const cv::Mat behind = inv_depth < double(ws[ws.size() / 10]) * 0.95;
    out.setTo(0, behind & ~region);
  }
  // No opening here: it erases whatever is under 3 px wide (a thin rod's whole mask); GrabCut's
  // specks go with the small regions.
  return clean_region(out, min_pixels, inv_depth);
}

}  // namespace nova::masks

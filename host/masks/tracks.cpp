// Objects from the moving regions (masks_steps.hpp): connected regions, each joined to the
// track whose last region (grown by a margin for the motion between frames) it overlaps most.
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "masks/masks_steps.hpp"

namespace nova::masks {
namespace {

struct Track {
  std::vector<cv::Mat> masks;  // per frame; empty where not seen
  cv::Mat last;                // the last region seen, grown
  int last_frame = -1, seen = 0;
  double area = 0, sx = 0, sy = 0;  // total area and centroid sums
};

cv::Point2d centroid_of(const Track& t) { return {t.sx / std::max(t.area, 1.0), t.sy / std::max(t.area, 1.0)}; }

}  // namespace

std::vector<std::vector<cv::Mat>> track_objects(const std::vector<cv::Mat>& regions,
                                                const MotionMaskOptions& options,
                                                std::vector<std::string>& notes) {
  const int n = int(regions.size());
  if (!n) return {};
  const cv::Size size = regions[0].size();
  const int grow = std::max(3, int(0.06 * std::min(size.width, size.height)));
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * grow + 1, 2 * grow + 1));
  const int min_pixels = std::max(4, int(options.min_area * size.area()));
  std::vector<Track> tracks;
  for (int i = 0; i < n; ++i) {
    cv::Mat labels, stats, centroids;
    const int count = cv::connectedComponentsWithStats(regions[size_t(i)], labels, stats, centroids, 8, CV_32S);
    std::vector<std::pair<int, cv::Mat>> assigned;  // track, component
    for (int k = 1; k < count; ++k) {
      if (stats.at<int>(k, cv::CC_STAT_AREA) < min_pixels) continue;
      const cv::Mat comp = labels == k;
      int best = -1, best_overlap = 0;
      for (size_t t = 0; t < tracks.size(); ++t) {
        if (tracks[t].last.empty() || tracks[t].last_frame < i - 2) continue;  // new, or lost for more than one frame
        const int overlap = cv::countNonZero(comp & tracks[t].last);
        if (overlap > best_overlap) best = int(t), best_overlap = overlap;
      }
      if (best < 0) {
        tracks.push_back(Track{});
        tracks.back().masks.assign(size_t(n), cv::Mat());
        best = int(tracks.size()) - 1;
      }
      assigned.push_back({best, comp});
    }
    for (auto& [t, comp] : assigned) {
      Track& tr = tracks[size_t(t)];
      cv::Mat& m = tr.masks[size_t(i)];
      m = m.empty() ? comp.clone() : (m | comp);
    }
    for (auto& tr : tracks) {
      const cv::Mat& m = tr.masks[size_t(i)];
      if (m.empty()) continue;
      cv::dilate(m, tr.last, kernel);
      tr.last_frame = i;
      ++tr.seen;
      const cv::Moments mo = cv::moments(m, true);
      tr.area += mo.m00, tr.sx += mo.m10, tr.sy += mo.m01;
    }
  }
  // Objects: tracks seen in enough frames, largest first.
  const int needed = std::max(2, int(std::ceil(options.min_track_frames * n)));
  std::vector<Track> kept;
  int dropped = 0;
  for (auto& t : tracks) (t.seen >= std::min(needed, n) ? kept.push_back(std::move(t)) : void(++dropped));
  std::sort(kept.begin(), kept.end(), [](const Track& a, const Track& b) { return a.area > b.area; });
  if (dropped) notes.push_back(std::to_string(dropped) + " moving region track(s) seen in fewer than " +
                               std::to_string(needed) + " frames dropped");
  const size_t found = kept.size();
  if (options.objects > 0 && kept.size() > size_t(options.objects)) {
    // The smaller tracks join the nearest of the K largest, frame by frame.
    for (size_t t = size_t(options.objects); t < kept.size(); ++t) {
      const cv::Point2d c = centroid_of(kept[t]);
      size_t nearest = 0;
      double best = 1e300;
      for (size_t k = 0; k < size_t(options.objects); ++k) {
        const cv::Point2d d = centroid_of(kept[k]) - c;
        if (d.dot(d) < best) best = d.dot(d), nearest = k;
      }
      for (int i = 0; i < n; ++i) {
        const cv::Mat& m = kept[t].masks[size_t(i)];
        if (m.empty()) continue;
        cv::Mat& into = kept[nearest].masks[size_t(i)];
        into = into.empty() ? m.clone() : (into | m);
      }
    }
    kept.resize(size_t(options.objects));
    notes.push_back(std::to_string(found) + " moving objects found; the smaller ones merged into the nearest of the " +
                    std::to_string(options.objects) + " largest (--objects)");
  } else if (options.objects > 0 && kept.size() < size_t(options.objects)) {
    notes.push_back("--objects " + std::to_string(options.objects) + " asked, but only " + std::to_string(found) +
                    " moving object(s) found: writing " + std::to_string(found));
  }
  std::vector<std::vector<cv::Mat>> out;
  for (auto& t : kept) {
    for (auto& m : t.masks)
      if (m.empty()) m = cv::Mat(size, CV_8U, cv::Scalar(0));
    out.push_back(std::move(t.masks));
  }
  return out;
}

}  // namespace nova::masks

// Objects from the moving regions (masks_steps.hpp): connected regions, each joined to a track
// whose reach it overlaps (the track's last region and where its velocity takes it, grown by a
// margin), preferring a track for which it is the best overlap. A region that is the best of two
// tracks, each overlapping it with much of its last area, is two objects touching in the image
// (one passing in front of the other, or crossing its path): its pixels are split between them
// by where each track's last region has moved at its velocity from before they met and by
// depth, so that objects that cross keep their own tracks.
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "masks/masks_steps.hpp"

namespace nova::masks {
namespace {

struct Track {
  std::vector<cv::Mat> masks;  // per frame; empty where not seen
  cv::Mat last;                // the last region seen
  int last_frame = -1, seen = 0;
  cv::Point2d last_centre, velocity;  // px a frame; kept through frames where it was split off
  bool moving = false;                // velocity measured
  bool split = false;                 // the last region was split off a shared one
  double last_area = 0;
  double depth = 0;                   // median inverse depth of the last region
  double area = 0, sx = 0, sy = 0;  // total area and centroid sums
};

cv::Point2d centroid_of(const Track& t) { return {t.sx / std::max(t.area, 1.0), t.sy / std::max(t.area, 1.0)}; }

// Where the track's last region would be in frame i at its velocity (none before it has been
// seen twice).
cv::Mat predicted_region(const Track& t, int i) {
  if (!t.moving) return t.last;
  const cv::Point2d shift = t.velocity * double(i - t.last_frame);
  const cv::Mat m = (cv::Mat_<double>(2, 3) << 1, 0, shift.x, 0, 1, shift.y);
  cv::Mat out;
  cv::warpAffine(t.last, out, m, t.last.size(), cv::INTER_NEAREST, cv::BORDER_CONSTANT, cv::Scalar(0));
  return out;
}

// A component's pixels to the claimants, each pixel to the lowest cost: its distance (px) to
// the claimant's predicted region plus kDepthPx pixels per unit of relative difference from
// the claimant's inverse depth. Where the regions overlap (an object in front of another) the
// depth decides.
std::vector<cv::Mat> split_component(const cv::Mat& comp, const std::vector<cv::Mat>& regions,
                                     const std::vector<double>& depths, const cv::Mat& inv_depth) {
  constexpr double kDepthPx = 100;
  std::vector<cv::Mat> distance(regions.size());
  for (size_t c = 0; c < regions.size(); ++c) {
    cv::Mat outside = regions[c] == 0;
    cv::distanceTransform(outside, distance[c], cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  }
  std::vector<cv::Mat> parts(regions.size());
  for (auto& p : parts) p = cv::Mat(comp.size(), CV_8U, cv::Scalar(0));
  for (int y = 0; y < comp.rows; ++y)
    for (int x = 0; x < comp.cols; ++x) {
      if (!comp.at<uchar>(y, x)) continue;
      const double w = inv_depth.at<float>(y, x);
      size_t best = 0;
      double best_cost = 0;
      for (size_t c = 0; c < regions.size(); ++c) {
        const double relative = depths[c] > 0 ? std::abs(w / depths[c] - 1.0) : 0.0;
        const double cost = distance[c].at<float>(y, x) + kDepthPx * relative;
        if (c == 0 || cost < best_cost) best = c, best_cost = cost;
      }
      parts[best].at<uchar>(y, x) = 255;
    }
  return parts;
}

}  // namespace

std::vector<std::vector<cv::Mat>> track_objects(const std::vector<cv::Mat>& regions,
                                                const std::vector<cv::Mat>& inv_depth,
                                                const MotionMaskOptions& options,
                                                std::vector<std::string>& notes) {
  const int n = int(regions.size());
  if (!n) return {};
  const cv::Size size = regions[0].size();
  const int grow = std::max(3, int(0.06 * std::min(size.width, size.height)));
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * grow + 1, 2 * grow + 1));
  const int min_pixels = std::max(4, int(options.min_area * size.area()));
  // A track claims a region its reach overlaps by this fraction of its last area (its object is
  // mostly in there, not just grazing it with the grown margin) once it has been seen twice (a
  // region seen once is as likely a flicker of the score as an object).
  constexpr double kClaim = 0.3;
  std::vector<Track> tracks;
  int splits = 0;
  for (int i = 0; i < n; ++i) {
    cv::Mat labels, stats, centroids;
    const int count = cv::connectedComponentsWithStats(regions[size_t(i)], labels, stats, centroids, 8, CV_32S);
    std::vector<cv::Mat> comps(size_t(std::max(count, 1)));
    for (int k = 1; k < count; ++k)
      if (stats.at<int>(k, cv::CC_STAT_AREA) >= min_pixels) comps[size_t(k)] = labels == k;
    // Each live track's reach (its last region and where its velocity takes it, grown) and
    // the component it overlaps most.
    const size_t live = tracks.size();
    std::vector<std::vector<int>> overlap(live, std::vector<int>(comps.size(), 0));
    std::vector<int> best_comp(live, -1);
    std::vector<cv::Mat> predicted(live);
    for (size_t t = 0; t < live; ++t) {
      if (tracks[t].last.empty() || tracks[t].last_frame < i - 2) continue;  // lost for more than one frame
      predicted[t] = predicted_region(tracks[t], i);
      cv::Mat reach;
      cv::dilate(tracks[t].last | predicted[t], reach, kernel);
      for (size_t k = 1; k < comps.size(); ++k) {
        if (comps[k].empty()) continue;
        overlap[t][k] = cv::countNonZero(comps[k] & reach);
        if (overlap[t][k] > 0 && (best_comp[t] < 0 || overlap[t][k] > overlap[t][size_t(best_comp[t])]))
          best_comp[t] = int(k);
      }
    }
    std::vector<std::pair<int, cv::Mat>> assigned;  // track, pixels
    std::vector<bool> split(live, false);
    for (size_t k = 1; k < comps.size(); ++k) {
      if (comps[k].empty()) continue;
      std::vector<size_t> claimants;
      for (size_t t = 0; t < live; ++t)
        if (best_comp[t] == int(k) && tracks[t].seen >= 2 && overlap[t][k] >= kClaim * tracks[t].last_area)
          claimants.push_back(t);
      if (claimants.size() >= 2) {
        std::vector<cv::Mat> regions;
        std::vector<double> depths;
        for (size_t t : claimants) {
          regions.push_back(predicted[t]);
          depths.push_back(tracks[t].depth);
        }
        const std::vector<cv::Mat> parts = split_component(comps[k], regions, depths, inv_depth[size_t(i)]);
        for (size_t c = 0; c < claimants.size(); ++c) {
          split[claimants[c]] = true;
          if (cv::countNonZero(parts[c])) assigned.push_back({int(claimants[c]), parts[c]});
        }
        ++splits;
        continue;
      }
      // The track that overlaps it most among those whose best it is, else among all; else a
      // new track.
      int best = -1;
      for (int pass = 0; pass < 2 && best < 0; ++pass)
        for (size_t t = 0; t < live; ++t)
          if (overlap[t][k] > 0 && (pass == 1 || best_comp[t] == int(k)) &&
              (best < 0 || overlap[t][k] > overlap[size_t(best)][k]))
            best = int(t);
      if (best < 0) {
        tracks.push_back(Track{});
        tracks.back().masks.assign(size_t(n), cv::Mat());
        best = int(tracks.size()) - 1;
      }
      assigned.push_back({best, comps[k]});
    }
    for (auto& [t, comp] : assigned) {
      Track& tr = tracks[size_t(t)];
      cv::Mat& m = tr.masks[size_t(i)];
      m = m.empty() ? comp.clone() : (m | comp);
    }
    for (size_t t = 0; t < tracks.size(); ++t) {
      Track& tr = tracks[t];
      const cv::Mat& m = tr.masks[size_t(i)];
      if (m.empty()) continue;
      const cv::Moments mo = cv::moments(m, true);
      const cv::Point2d centre{mo.m10 / std::max(mo.m00, 1.0), mo.m01 / std::max(mo.m00, 1.0)};
      const bool was_split = t < live && split[t];
      // A centre split off a shared region (or the first one after it) says little about the
      // object's motion: the velocity from before carries the track through the crossing.
      if (tr.last_frame >= 0 && !was_split && !tr.split) {
        tr.velocity = (centre - tr.last_centre) / double(i - tr.last_frame);
        tr.moving = true;
      }
      tr.split = was_split;
      tr.last = m;
      tr.last_frame = i;
      tr.last_centre = centre;
      tr.last_area = mo.m00;
      tr.depth = median_inverse_depth(m, inv_depth[size_t(i)]);
      ++tr.seen;
      tr.area += mo.m00, tr.sx += mo.m10, tr.sy += mo.m01;
    }
  }
  if (splits) notes.push_back(std::to_string(splits) + " region(s) that two objects' tracks both claim split between them");
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

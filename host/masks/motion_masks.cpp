// make_motion_masks and write_motion_masks (include/nova/masks/motion_masks.hpp): the steps of
// masks_steps.hpp in order, and the motion_masks folder with its check pictures.
#include "nova/masks/motion_masks.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "data/fs_util.hpp"
#include "masks/masks_steps.hpp"
#include "nova/train/disparity_fit.hpp"
#include "nova/runtime/error.hpp"
#include "nova/io/image_io.hpp"
#include "nova/io/charts.hpp"
#include "nova/io/pictures.hpp"

namespace nova {
namespace {

Image8 to_image(const cv::Mat& m) {
  Image8 out(m.cols, m.rows, 1);
  for (int y = 0; y < m.rows; ++y) std::copy_n(m.ptr<uint8_t>(y), m.cols, &out.data[size_t(y) * m.cols]);
  return out;
}

ImageF to_imagef(const cv::Mat& m) {
  ImageF out;
  out.width = m.cols, out.height = m.rows;
  out.data.assign(m.begin<float>(), m.end<float>());
  return out;
}

void report(const MotionMaskOptions& o, const std::string& line) {
  if (o.progress) o.progress(line);
}

}  // namespace

MotionMasks make_motion_masks(const Scene& scene, const MotionMaskOptions& options) {
  const int n = int(scene.frames.size());
  if (n < 2) throw Error(scene.source + ": " + std::to_string(n) + " frame(s); finding what moves needs at least 2");
  for (const Frame& f : scene.frames)
    if (f.disparity.empty())
      throw Error(scene.source + "/disp: missing; finding what moves needs a disparity map per frame (disp/NNN.npy, "
                  "e.g. from a monocular depth network)");
  if (options.offsets.empty()) throw Error("motion masks: no neighbour offsets");
  const auto t0 = std::chrono::steady_clock::now();
  auto seconds = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(); };
  MotionMasks out;
  std::vector<masks::FrameData> frames = masks::prepare_frames(scene);
  {
    // nova's disparity fit (disparity_fit.hpp) on every pixel: there are no masks yet, and its
    // truncated colour error keeps the moving pixels' pull small.
    DisparityFitOptions fo;
    fo.use_masks = false;
    fo.per_frame = options.per_frame_fit;
    const DisparityFit f = fit_disparity(scene, fo);
    if (f.scale == 0 && f.shift == 0)  // fit_disparity gave up before searching
      throw Error(scene.source + "/disp: the disparity maps are flat or not finite: no depth to place pixels at");
    out.depth.global_scale = f.scale, out.depth.global_shift = f.shift, out.depth.cost = f.cost;
    out.depth.parallax = f.ok;
    out.depth.scale = options.per_frame_fit ? f.frame_scale : std::vector<double>(size_t(n), f.scale);
    out.depth.shift = options.per_frame_fit ? f.frame_shift : std::vector<double>(size_t(n), f.shift);
  }
  masks::apply_depth(frames, out.depth);
  {
    std::ostringstream s;
    s << "depth: inverse depth = " << out.depth.global_scale << " disparity + " << out.depth.global_shift
      << " (colour error " << out.depth.cost << ")" << (options.per_frame_fit ? ", refined per frame" : "")
      << (out.depth.parallax ? "" : "; warning: no better than a constant depth (too little parallax to place the disparity)");
    out.notes.push_back(s.str());
    char t[64];
    std::snprintf(t, sizeof t, " (%.1f s)", seconds());
    report(options, s.str() + t);
  }

  // Raw scores (the peel reads a pixel's own) and smoothed ones (the threshold and the regions).
  std::vector<cv::Mat> raw_scores, scores;
  for (int i = 0; i < n; ++i) {
    raw_scores.push_back(masks::motion_score(frames, i, options));
    cv::Mat s;
    cv::GaussianBlur(raw_scores.back(), s, cv::Size(0, 0), 1.0);
    scores.push_back(s);
    if ((i + 1) % std::max(1, n / 4) == 0 || i + 1 == n) {
      char line[96];
      std::snprintf(line, sizeof line, "scores: %d / %d frames (%.1f s)", i + 1, n, seconds());
      report(options, line);
    }
  }
  out.threshold = masks::score_threshold(scores, options, out.notes);
  report(options, out.notes.back());

  std::vector<cv::Mat> regions;
  for (int i = 0; i < n; ++i)
    regions.push_back(masks::moving_region(scores[size_t(i)], raw_scores[size_t(i)], out.threshold,
                                           scene.frames[size_t(i)].rgb, frames, i, options));
  {
    char line[96];
    std::snprintf(line, sizeof line, "regions: %d frames (%.1f s)", n, seconds());
    report(options, line);
  }
  std::vector<cv::Mat> inv_depth;
  for (const auto& f : frames) inv_depth.push_back(f.inv_depth);
  std::vector<std::vector<cv::Mat>> objects = masks::track_objects(regions, inv_depth, options, out.notes);

  const int w = scene.frames[0].rgb.width, h = scene.frames[0].rgb.height;
  out.nothing_moves = objects.empty();
  if (out.nothing_moves) {
    out.notes.push_back("nothing moves: no region scored above the threshold in enough frames; the masks are all "
                        "background (object 1 empty)");
    objects.assign(1, std::vector<cv::Mat>(size_t(n), cv::Mat(h, w, CV_8U, cv::Scalar(0))));
  }
  out.masks.assign(objects.size() + 1, {});
  for (int i = 0; i < n; ++i) {
    cv::Mat any(h, w, CV_8U, cv::Scalar(0));
    for (size_t k = 0; k < objects.size(); ++k) {
      // An object's pixels that an earlier (larger) object already claims stay with it.
      cv::Mat own = objects[k][size_t(i)] & ~any;
      any |= own;
      out.masks[k + 1].push_back(to_image(own));
    }
    out.masks[0].push_back(to_image(~any));
    out.scores.push_back(to_imagef(scores[size_t(i)]));
  }
  out.notes.push_back(std::to_string(out.objects()) + " object(s), " + std::to_string(n) + " frames at " +
                      std::to_string(w) + "x" + std::to_string(h));
  return out;
}

Image8 objects_union(const std::vector<Image8>& masks_of_frame) {
  if (masks_of_frame.empty()) return {};
  Image8 out(masks_of_frame[0].width, masks_of_frame[0].height, 1);
  for (size_t k = 1; k < masks_of_frame.size(); ++k)
    for (size_t p = 0; p < out.data.size(); ++p)
      if (masks_of_frame[k].data[p]) out.data[p] = 255;
  return out;
}

double mask_iou(const Image8& a, const Image8& b) {
  if (a.width != b.width || a.height != b.height || a.channels != b.channels)
    throw Error("mask_iou: masks of different sizes");
  size_t inter = 0, uni = 0;
  for (size_t p = 0; p < a.data.size(); ++p) {
    inter += a.data[p] && b.data[p];
    uni += a.data[p] || b.data[p];
  }
  return uni ? double(inter) / double(uni) : 1.0;
}

namespace {

// Frame | score (viridis, bright = high, saturating at twice the threshold) | masks over the frame.
Image8 check_picture(const Frame& frame, const MotionMasks& m, size_t i) {
  static const uint8_t colours[6][3] = {{230, 60, 60}, {60, 120, 230}, {240, 200, 40},
                                        {60, 200, 90}, {200, 80, 220}, {40, 210, 210}};
  const ImageF& s = m.scores[i];
  std::vector<float> neg(s.data.size());
  for (size_t p = 0; p < neg.size(); ++p) neg[p] = -s.data[p];
  const Image8 score = depth_to_color(neg, s.width, s.height, float(-2 * m.threshold), 0.0f);
  Image8 over = frame.rgb;
  for (size_t k = 1; k < m.masks.size(); ++k) {
    const uint8_t* c = colours[(k - 1) % 6];
    const Image8& mk = m.masks[k][i];
    for (size_t p = 0; p < mk.data.size(); ++p)
      if (mk.data[p])
        for (int ch = 0; ch < 3; ++ch) over.data[p * 3 + ch] = uint8_t((over.data[p * 3 + ch] + c[ch]) / 2);
  }
  return image_row({frame.rgb, score, over}, {frame.name, "motion score", "masks"});
}

std::string frame_file(size_t i) {
  char name[32];
  std::snprintf(name, sizeof name, "%03zu.png", i);
  return name;
}

}  // namespace

void write_motion_masks(const Scene& scene, const MotionMasks& masks, const std::string& out_dir, bool replace) {
  data::StagedDir staged(out_dir, replace);
  const auto& root = staged.path();
  for (size_t k = 0; k < masks.masks.size(); ++k) {
    data::fs::create_directories(root / std::to_string(k));
    for (size_t i = 0; i < masks.masks[k].size(); ++i)
      write_png((root / std::to_string(k) / frame_file(i)).string(), masks.masks[k][i]);
  }
  data::fs::create_directories(root / "check");
  for (size_t i = 0; i < scene.frames.size(); ++i)
    write_png((root / "check" / frame_file(i)).string(), check_picture(scene.frames[i], masks, i));
  std::ofstream notes(root / "masks.txt");
  notes << "# nova masks: " << scene.source << "\n";
  for (const auto& line : masks.notes) notes << line << "\n";
  notes.close();
  if (!notes) throw Error((root / "masks.txt").string() + ": cannot write");
  staged.commit();
}

}  // namespace nova

// Readers for poses_bounds.npy layouts: NOVA / DynamicNeRF (with masks, disparity, ground
// truth) and plain LLFF (static). Pose processing follows the reference loader; see
// include/nova/data/llff_poses.hpp.
#include <algorithm>
#include <cmath>
#include <sstream>

#include "data/fs_util.hpp"
#include "nova/runtime/error.hpp"
#include "nova/io/compose_spec_text.hpp"
#include "nova/io/image_io.hpp"
#include "nova/sampling/camera.hpp"
#include "nova/data/llff_poses.hpp"
#include "nova/io/npy.hpp"
#include "nova/data/scene_io.hpp"

namespace nova {
namespace {

using data::fs::path;
namespace fs = data::fs;

const std::vector<std::string> kImageExts = {".png", ".jpg", ".jpeg"};

struct PosesBounds {
  std::vector<Pose34> c2w;  // raw, OpenGL axes
  std::vector<double> near, far;
  std::vector<std::array<double, 3>> hwf;
};

std::string num(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// Reads and validates poses_bounds.npy (N x 17, finite, 0 < near < far).
PosesBounds read_poses_bounds(const path& file) {
  if (!fs::exists(file)) throw Error(file.string() + ": missing (need N x 17 poses and bounds)");
  const NpyArray a = read_npy(file.string());
  if (a.shape.size() != 2 || a.shape[1] != 17 || a.shape[0] == 0) {
    std::string s = "(";
    for (size_t i = 0; i < a.shape.size(); ++i) s += (i ? ", " : "") + std::to_string(a.shape[i]);
    throw Error(file.string() + ": shape " + s + ") is not (N, 17) with N >= 1");
  }
  PosesBounds pb;
  const size_t n = a.shape[0];
  for (size_t r = 0; r < n; ++r) {
    const double* row = &a.values[r * 17];
    for (int c = 0; c < 17; ++c)
      if (!std::isfinite(row[c]))
        throw Error(file.string() + ": row " + std::to_string(r) + " column " +
                    std::to_string(c) + " is " + (std::isnan(row[c]) ? "NaN" : "Inf") +
                    " (poses and bounds must be finite)");
    if (row[15] <= 0)
      throw Error(file.string() + ": row " + std::to_string(r) + " has near bound " +
                  num(row[15]) + " <= 0");
    if (row[16] <= row[15])
      throw Error(file.string() + ": row " + std::to_string(r) + " has far bound " +
                  num(row[16]) + " <= near bound " + num(row[15]));
    // The 3x3 part must be a rotation: rays are built from its columns as unit axes. 1e-3
    // passes poses stored in float32 or printed with six digits.
    const double worst = axes_deviation(row, 5);
    if (worst > 1e-3)
      throw Error(file.string() + ": row " + std::to_string(r) + ": the camera's 3x3 axes are not orthonormal " +
                  "(largest deviation of R^T R from the identity " + num(worst) + ")");
    pb.c2w.push_back(llff_row_to_gl(row));
    pb.near.push_back(row[15]);
    pb.far.push_back(row[16]);
    pb.hwf.push_back({row[4], row[9], row[14]});
  }
  return pb;
}

// Chooses the image folder for `factor` (see LoadOptions::factor); sets `resize` when the
// images must be downscaled here because images_F/ does not exist.
path image_folder(const path& dir, int& factor, bool& resize) {
  resize = false;
  if (factor < 0) throw Error("--factor must be >= 1 (or 0 for automatic)");
  if (factor == 0) {
    if (fs::is_directory(dir / "images")) {
      factor = 1;
      return dir / "images";
    }
    std::vector<int> found;
    for (int f = 2; f <= 64; ++f)
      if (fs::is_directory(dir / ("images_" + std::to_string(f)))) found.push_back(f);
    if (found.size() != 1)
      throw Error(dir.string() + ": " +
                  (found.empty() ? std::string("no images/ folder")
                                 : std::string("several images_F/ folders; pick one with --factor")));
    factor = found[0];
    return dir / ("images_" + std::to_string(factor));
  }
  if (factor == 1) {
    if (!fs::is_directory(dir / "images")) throw Error((dir / "images").string() + ": missing");
    return dir / "images";
  }
  const path pre = dir / ("images_" + std::to_string(factor));
  if (fs::is_directory(pre)) return pre;
  if (!fs::is_directory(dir / "images"))
    throw Error(dir.string() + ": neither " + pre.filename().string() + "/ nor images/ exists");
  resize = true;
  return dir / "images";
}

std::string relative_name(const path& p, const path& base) {
  return fs::relative(p, base).string();
}

// One mask folder: N PNGs resized (nearest) to the frame size.
std::vector<Image8> read_mask_folder(const path& folder, const path& dir, size_t n, int w, int h,
                                     std::vector<std::string>& notes) {
  const auto files = data::list_files(folder, {".png"});
  if (files.size() != n)
    throw Error(folder.string() + ": " + std::to_string(files.size()) + " masks but " +
                std::to_string(n) + " images (mask count must match the frames)");
  std::vector<Image8> masks;
  size_t resized = 0;
  int mw = 0, mh = 0;
  for (const auto& f : files) {
    const Image8 m = read_mask(f.string());
    if (m.width != w || m.height != h) {
      ++resized;
      mw = m.width;
      mh = m.height;
    }
    // Another resolution of the same picture is resized, as DynamicNeRF does; another aspect
    // ratio means a mask of another video or crop, which stretching would misplace.
    const double height_at_frame_width = static_cast<double>(m.height) * w / std::max(1, m.width);
    if (std::abs(height_at_frame_width - h) > 1.0 + 0.01 * h)
      throw Error(f.string() + ": the mask is " + std::to_string(m.width) + "x" + std::to_string(m.height) +
                  ", its frame " + std::to_string(w) + "x" + std::to_string(h) +
                  ": another aspect ratio (a mask of another video or crop?); a mask may differ from its "
                  "frame in resolution only");
    masks.push_back(resize_nearest(m, w, h));
  }
  if (resized)
    notes.push_back(relative_name(folder, dir) + "/: " + std::to_string(resized) + " mask(s) at " + std::to_string(mw) +
                    "x" + std::to_string(mh) + " (e.g.) resized, nearest, to the frames' " + std::to_string(w) + "x" +
                    std::to_string(h));
  return masks;
}

// gt/ holds images at the full resolution of images/: with --factor F they are downscaled as
// the frames are (the views' focal follows their width), so that renders and truth match.
void read_ground_truth(const path& dir, Scene& scene, const WorldTransform& world,
                       const std::vector<Camera>& frame_cams, int factor) {
  const path gt = dir / "gt";
  const path views = gt / "views.txt";
  if (fs::exists(views)) {
    const PosesBounds pb = read_poses_bounds(gt / "poses_bounds.npy");
    std::istringstream in(data::read_text(views));
    std::string line;
    size_t row = 0;
    int line_no = 0;
    while (std::getline(in, line)) {
      ++line_no;
      if (line.empty() || line[0] == '#') continue;
      GroundTruthView v;
      std::istringstream ls(line);
      if (!(ls >> v.name >> v.kind >> v.time_index))
        throw Error(views.string() + ":" + std::to_string(line_no) +
                    ": expected 'IMAGE KIND TIME_INDEX'");
      if (row >= pb.c2w.size())
        throw Error(views.string() + ": more views than rows in gt/poses_bounds.npy");
      if (v.time_index < 0 || v.time_index >= int(scene.frames.size()))
        throw Error(views.string() + ":" + std::to_string(line_no) + ": time index " +
                    std::to_string(v.time_index) + " out of range");
      const Image8 full = read_rgb((gt / v.name).string());
      v.rgb = downscale_by(full, factor, (gt / v.name).string());
      const path objects = gt / ground_truth_objects_name(v.name);
      if (fs::exists(objects)) {
        v.objects = read_mask(objects.string());
        if (v.objects.width != full.width || v.objects.height != full.height)
          throw Error(objects.string() + ": " + std::to_string(v.objects.width) + "x" +
                      std::to_string(v.objects.height) + ", not the size of its image (" +
                      std::to_string(full.width) + "x" + std::to_string(full.height) + ")");
        v.objects = resize_nearest(v.objects, v.rgb.width, v.rgb.height);
      }
      v.time = frame_time(v.time_index, int(scene.frames.size()));
      const Camera& ref = frame_cams[0];
      v.camera = ref;
      v.camera.width = v.rgb.width;
      v.camera.height = v.rgb.height;
      // The same intrinsics rule as the frames: focal scaled by the image width ratio.
      v.camera.fx = v.camera.fy = pb.hwf[row][2] * v.rgb.width / pb.hwf[row][1];
      v.camera.cx = 0.5 * v.rgb.width;
      v.camera.cy = 0.5 * v.rgb.height;
      v.camera.c2w = world.apply(pb.c2w[row]);
      scene.gt_views.push_back(std::move(v));
      ++row;
    }
    if (row != pb.c2w.size())
      throw Error(views.string() + ": " + std::to_string(row) + " views but " +
                  std::to_string(pb.c2w.size()) + " rows in gt/poses_bounds.npy");
    scene.notes.push_back("gt/: " + std::to_string(scene.gt_views.size()) + " ground-truth views");
  }
  const path spec = gt / "compose" / "spec.txt";
  if (fs::exists(spec)) {
    const ComposeSpec cs = read_compose_spec(spec.string());
    for (const auto& t : cs.targets) {
      if (t.camera >= int(scene.frames.size()))
        throw Error(spec.string() + ": target '" + t.name + "' uses camera " +
                    std::to_string(t.camera) + " but the scene has " +
                    std::to_string(scene.frames.size()) + " frames");
      for (const auto& i : t.instances)
        if (i.object > scene.num_objects) {
          // Masks were merged or dropped (e.g. --static-only): the targets no longer apply.
          scene.notes.push_back("gt/compose/ ignored: target '" + t.name + "' uses object " +
                                std::to_string(i.object) + " but the scene has " +
                                std::to_string(scene.num_objects));
          return;
        }
    }
    scene.compose = cs;
    for (const auto& t : scene.compose.targets) {
      const path img = gt / "compose" / (t.name + ".png");
      if (!fs::exists(img)) continue;
      ComposeTargetImage ti{t.name, downscale_by(read_rgb(img.string()), factor, img.string()), {}};
      const path objects = gt / ground_truth_objects_name("compose/" + t.name + ".png");
      if (fs::exists(objects)) ti.objects = resize_nearest(read_mask(objects.string()), ti.rgb.width, ti.rgb.height);
      scene.compose_gt.push_back(std::move(ti));
    }
    scene.notes.push_back("gt/compose/: " + std::to_string(scene.compose.targets.size()) +
                          " composition targets, " + std::to_string(scene.compose_gt.size()) +
                          " with images");
  }
}

Scene load_poses_layout(const path& dir, const LoadOptions& opt, bool nova) {
  if (!fs::is_directory(dir)) throw Error(dir.string() + ": not a folder");
  if (opt.split != "train")
    throw Error("--split " + opt.split + ": " + dir.string() + " is " + (nova ? "a NOVA" : "an LLFF") +
                " folder, which has no splits (hold frames out with --holdout and score them with "
                "nova eval --views heldout)");
  Scene scene;
  scene.name = fs::absolute(dir).lexically_normal().filename().string();
  if (scene.name.empty()) scene.name = fs::absolute(dir).lexically_normal().parent_path().filename().string();
  scene.source = dir.string();
  scene.format = nova ? "nova" : "llff";
  scene.ndc = true;
  scene.has_time = nova;
  scene.bd_factor = nova ? 0.9 : 0.75;

  const path poses_file = dir / "poses_bounds.npy";
  const PosesBounds pb = read_poses_bounds(poses_file);
  const size_t n = pb.c2w.size();

  int factor = opt.factor;
  bool resize = false;
  const path img_dir = image_folder(dir, factor, resize);
  const auto files = data::list_files(img_dir, kImageExts);
  if (files.size() != n)
    throw Error(img_dir.string() + ": " + std::to_string(files.size()) + " images but " +
                poses_file.string() + " has " + std::to_string(n) + " rows (" +
                (files.size() < n ? "missing frames" : "extra frames") + ")");

  // Frames, at one size.
  int w = 0, h = 0;
  size_t with_alpha = 0;
  for (size_t i = 0; i < n; ++i) {
    Frame f;
    f.name = files[i].filename().string();
    bool alpha = false;
    f.rgb = read_rgb(files[i].string(), false, &alpha);
    with_alpha += alpha;
    if (resize) f.rgb = downscale_by(f.rgb, factor, files[i].string());
    if (i == 0) {
      w = f.rgb.width;
      h = f.rgb.height;
    } else if (f.rgb.width != w || f.rgb.height != h) {
      throw Error(files[i].string() + ": size " + std::to_string(f.rgb.width) + "x" +
                  std::to_string(f.rgb.height) + " differs from the first image's " +
                  std::to_string(w) + "x" + std::to_string(h));
    }
    scene.frames.push_back(std::move(f));
  }
  scene.notes.push_back("images: " + std::to_string(n) + " from " + relative_name(img_dir, dir) + "/" +
                        (resize ? " downscaled by " + std::to_string(factor) + " (area)" : "") +
                        " at " + std::to_string(w) + "x" + std::to_string(h));
  if (with_alpha)
    scene.notes.push_back("images: " + std::to_string(with_alpha) + " with an alpha channel, dropped (frames are opaque)");

  // Masks: one folder per NeRF, or one folder with the moving region, or none.
  const path mask_dir = dir / "motion_masks";
  std::vector<std::vector<Image8>> masks;  // [nerf][frame]
  if (nova && fs::is_directory(mask_dir) && !opt.static_only) {
    const auto sub = data::numbered_subdirs(mask_dir);
    if (!sub.empty()) {
      for (size_t k = 0; k < sub.size(); ++k)
        if (sub[k].first != int(k))
          throw Error(mask_dir.string() + ": mask folders must be numbered 0..K without gaps (" +
                      "found " + sub[k].second.filename().string() + " where " +
                      std::to_string(k) + " was expected)");
      if (sub.size() < 2)
        throw Error(mask_dir.string() + ": only folder 0 (background); objects need 1..K");
      for (const auto& [k, folder] : sub) masks.push_back(read_mask_folder(folder, dir, n, w, h, scene.notes));
      scene.notes.push_back("motion_masks/: folders 0.." + std::to_string(sub.size() - 1) +
                            " (0 = background)");
    } else {
      auto moving = read_mask_folder(mask_dir, dir, n, w, h, scene.notes);
      std::vector<Image8> background;
      for (const auto& m : moving) {
        Image8 b = m;
        for (auto& v : b.data) v = v ? 0 : 255;
        background.push_back(std::move(b));
      }
      masks.push_back(std::move(background));
      masks.push_back(std::move(moving));
      scene.notes.push_back("motion_masks/: one folder with the moving region (DynamicNeRF "
                            "layout): K = 1, background = its complement");
    }
  } else if (nova && !opt.static_only) {
    throw Error(mask_dir.string() + ": missing; NOVA needs one mask folder per NeRF "
                "(motion_masks/0 = background, 1..K = objects). To load it as static-only "
                "(K = 0): nova train --static-only true, nova scene --static-only");
  } else {
    if (nova && fs::is_directory(mask_dir))
      scene.notes.push_back("motion_masks/ present but ignored (--static-only)");
    else if (nova)
      scene.notes.push_back("no motion_masks/: loaded as static-only (K = 0), as asked");
    masks.push_back(std::vector<Image8>(n, Image8(w, h, 1, 255)));
  }
  scene.num_objects = int(masks.size()) - 1;
  // With masks from motion_masks/ (not the static-only stand-in), a NeRF whose mask is empty
  // in every frame learns nothing, or (the background's) learns to be empty.
  for (size_t k = 0; masks.size() > 1 && k < masks.size(); ++k) {
    const bool empty = std::all_of(masks[k].begin(), masks[k].end(), [](const Image8& m) {
      return std::all_of(m.data.begin(), m.data.end(), [](uint8_t v) { return v == 0; });
    });
    if (!empty) continue;
    scene.notes.push_back(k == 0 ? std::string("warning: the background's masks (motion_masks/0) are empty in every "
                                               "frame: the static NeRF is taught to be empty everywhere")
                                 : "warning: object " + std::to_string(k) +
                                       "'s masks are empty in every frame: its NeRF has nothing to learn");
  }
  for (size_t i = 0; i < n; ++i)
    for (auto& m : masks) scene.frames[i].masks.push_back(std::move(m[i]));

  // Disparity (optional).
  const path disp_dir = dir / "disp";
  if (nova && fs::is_directory(disp_dir)) {
    const auto dfiles = data::list_files(disp_dir, {".npy"});
    if (dfiles.size() != n)
      throw Error(disp_dir.string() + ": " + std::to_string(dfiles.size()) +
                  " disparity maps but " + std::to_string(n) + " images");
    double spread = 0, magnitude = 0;  // the largest standard deviation and |value| of any map
    for (size_t i = 0; i < n; ++i) {
      const NpyArray a = read_npy(dfiles[i].string());
      if (a.shape.size() != 2 && !(a.shape.size() == 3 && a.shape[2] == 1))
        throw Error(dfiles[i].string() + ": disparity must be 2-D (H, W), has " +
                    std::to_string(a.shape.size()) + " dimensions");
      const size_t cols = a.shape[1];
      for (size_t k = 0; k < a.values.size(); ++k)
        if (!std::isfinite(a.values[k]))
          throw Error(dfiles[i].string() + ": non-finite disparity " + std::to_string(a.values[k]) + " at row " +
                      std::to_string(k / cols) + ", column " + std::to_string(k % cols));
      ImageF d;
      d.height = int(a.shape[0]);
      d.width = int(a.shape[1]);
      d.data.assign(a.values.begin(), a.values.end());
      scene.frames[i].disparity = resize_nearest(d, w, h);
      double sum = 0, sq = 0, largest = 0;
      for (double v : a.values) {
        sum += v;
        sq += v * v;
        largest = std::max(largest, std::abs(v));
      }
      const double count = static_cast<double>(std::max<size_t>(a.values.size(), 1));
      spread = std::max(spread, std::sqrt(std::max(0.0, sq / count - (sum / count) * (sum / count))));
      magnitude = std::max(magnitude, largest);
    }
    scene.notes.push_back("disp/: " + std::to_string(n) + " disparity maps");
    // The depth terms standardise the disparity in float32 with a variance floor of 1e-6
    // (kernels/depth_loss.cl): a map that varies less, or whose squares overflow, says nothing.
    if (spread < 1e-3)
      scene.notes.push_back("warning: disp/ varies by less than 1e-3 (standard deviation " + num(spread) +
                            ") in every frame: the depth terms see it as flat; scale the maps up");
    else if (magnitude > 1e15)
      scene.notes.push_back("warning: disp/ holds values up to " + num(magnitude) +
                            ": too large for the depth terms' float32 sums; scale the maps down");
  }

  // Poses: reference processing, then cameras.
  const WorldTransform world = llff_world_transform(pb.c2w, pb.near, scene.bd_factor);
  std::vector<Camera> cams;
  for (size_t i = 0; i < n; ++i) {
    if (pb.hwf[i][1] <= 0 || pb.hwf[i][2] <= 0)
      throw Error(poses_file.string() + ": row " + std::to_string(i) +
                  " has a non-positive width or focal in its hwf column");
    Frame& f = scene.frames[i];
    f.camera.width = w;
    f.camera.height = h;
    // hwf holds the full-resolution size; the focal follows the image width (= f / factor,
    // as the reference computes it, when sizes divide exactly).
    f.camera.fx = f.camera.fy = pb.hwf[i][2] * w / pb.hwf[i][1];
    f.camera.cx = 0.5 * w;
    f.camera.cy = 0.5 * h;
    f.camera.c2w = world.apply(pb.c2w[i]);
    f.near = pb.near[i] * world.scale;
    f.far = pb.far[i] * world.scale;
    f.time = frame_time(int(i), int(n));
    cams.push_back(f.camera);
  }
  scene.near = scene.frames[0].near;
  scene.far = scene.frames[0].far;
  for (const auto& f : scene.frames) {
    scene.near = std::min(scene.near, f.near);
    scene.far = std::max(scene.far, f.far);
  }
  if (std::abs(pb.hwf[0][1] / w - factor) > 0.05 * factor)
    scene.notes.push_back("note: hwf width " + num(pb.hwf[0][1]) + " / image width " +
                          std::to_string(w) + " is not the factor " + std::to_string(factor) +
                          "; focal scaled by the width ratio");
  scene.notes.push_back("poses: bd_factor " + num(scene.bd_factor) + " (scale " +
                        num(world.scale) + "), recentred, NDC");

  if (nova && opt.load_gt && fs::is_directory(dir / "gt"))
    read_ground_truth(dir, scene, world, cams, factor);
  return scene;
}

}  // namespace

Scene load_nova_scene(const std::string& dir, const LoadOptions& opt) {
  return load_poses_layout(dir, opt, true);
}

Scene load_llff_scene(const std::string& dir, const LoadOptions& opt) {
  return load_poses_layout(dir, opt, false);
}

}  // namespace nova

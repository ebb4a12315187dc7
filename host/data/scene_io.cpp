// Format detection, the load_scene entry point, and the printed scene summary.
#include "nova/data/scene_io.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "data/fs_util.hpp"
#include "nova/runtime/error.hpp"
#include "nova/model/field_graphs.hpp"

namespace nova {

namespace fs = data::fs;

std::string detect_format(const std::string& dir_s, const LoadOptions& opt) {
  const fs::path dir(dir_s);
  if (fs::is_regular_file(dir) && dir.extension() == ".npz") return "npz";
  if (!fs::is_directory(dir)) throw Error(dir_s + ": not a folder");
  if (fs::exists(dir / "poses_bounds.npy")) {
    if (fs::exists(dir / "motion_masks") || fs::exists(dir / "disp") || fs::exists(dir / "gt"))
      return "nova";
    return "llff";
  }
  if (fs::exists(dir / ("transforms_" + opt.split + ".json"))) return "blender";
  if (data::list_files(dir, {".npz"}).size() == 1) return "npz";
  throw Error(dir_s + ": unknown scene layout (expected poses_bounds.npy, transforms_" +
              opt.split + ".json or one .npz)");
}

Scene load_scene(const std::string& dir, const LoadOptions& opt) {
  const std::string f = opt.format == "auto" ? detect_format(dir, opt) : opt.format;
  if (f == "nova" || f == "dynamicnerf") return load_nova_scene(dir, opt);
  if (f == "llff") return load_llff_scene(dir, opt);
  if (f == "blender" || f == "dnerf") return load_blender_scene(dir, opt);
  if (f == "npz") return load_dnerf_npz_scene(dir, opt);
  throw Error("unknown scene format '" + opt.format + "' (use auto, nova, llff, blender or npz)");
}

std::string scene_summary(const Scene& s) {
  std::ostringstream o;
  o << std::setprecision(4);
  o << "scene " << s.name << " (" << s.format << ", " << s.source << ")\n";
  if (s.frames.empty()) return o.str() + "  no frames\n";
  const Camera& c = s.frames[0].camera;
  o << "  frames      " << s.frames.size() << " at " << c.width << "x" << c.height
    << ", focal " << c.fx << ", principal point (" << c.cx << ", " << c.cy << ")\n";
  o << "  time        " << (s.has_time ? "" : "(static) ") << "[" << s.frames.front().time << ", "
    << s.frames.back().time << "]\n";
  o << "  NeRFs       " << s.num_nerfs() << " (1 static + " << s.num_objects << (s.num_objects == 1 ? " object)\n" : " objects)\n");
  o << "  mask cover ";
  for (int k = 0; k < s.num_nerfs(); ++k) {
    double sum = 0, n = 0;
    for (const auto& f : s.frames) {
      for (uint8_t v : f.masks[k].data) sum += v;
      n += double(f.masks[k].data.size());
    }
    o << " " << k << ":" << std::fixed << std::setprecision(1) << 100.0 * sum / (255.0 * n)
      << "%" << std::defaultfloat << std::setprecision(4);
  }
  o << "\n";
  o << "  rays        " << (s.ndc ? "NDC (forward-facing, near plane 1)" : "Euclidean")
    << ", bounds [" << s.near << ", " << s.far << "]";
  if (s.bd_factor > 0) o << " after bd_factor " << s.bd_factor;
  if (s.ndc) o << "; every training ray within |x|, |y| <= " << ray_geometry(s).extent;
  o << "\n";
  double span = 0;
  for (const auto& f : s.frames)
    for (int r = 0; r < 3; ++r)
      span = std::max(span, std::abs(f.camera.position(r) - s.frames[0].camera.position(r)));
  o << "  cameras     max offset from frame 0: " << span << "\n";
  o << "  disparity   " << (s.frames[0].disparity.empty() ? "none" : "yes") << "\n";
  const auto with_regions = std::count_if(s.gt_views.begin(), s.gt_views.end(),
                                          [](const GroundTruthView& v) { return !v.objects.empty(); });
  o << "  ground truth " << s.gt_views.size() << " views (" << with_regions << " with objects regions), "
    << s.compose.targets.size() << " composition targets\n";
  for (const auto& n : s.notes) o << "  - " << n << "\n";
  return o.str();
}

}  // namespace nova

// Blender / D-NeRF transforms_<split>.json reader: camera_angle_x, frames with file_path and a
// 4x4 camera-to-world transform_matrix (already OpenGL axes), and `time` in [0, 1] for D-NeRF.
#include <boost/property_tree/json_parser.hpp>
#include <boost/property_tree/ptree.hpp>
#include <cmath>

#include "data/fs_util.hpp"
#include "nova/error.hpp"
#include "nova/image_io.hpp"
#include "nova/scene_io.hpp"

namespace nova {

namespace fs = data::fs;
namespace pt = boost::property_tree;

Scene load_blender_scene(const std::string& dir_s, const LoadOptions& opt) {
  const fs::path dir(dir_s);
  const fs::path json = dir / ("transforms_" + opt.split + ".json");
  if (!fs::exists(json)) throw Error(json.string() + ": missing");
  pt::ptree root;
  try {
    pt::read_json(json.string(), root);
  } catch (const pt::json_parser_error& e) {
    throw Error(json.string() + ":" + std::to_string(e.line()) + ": bad JSON (" + e.message() + ")");
  }
  Scene scene;
  scene.name = fs::absolute(dir).lexically_normal().filename().string();
  scene.source = dir.string();
  scene.format = "blender";
  scene.near = 2;
  scene.far = 6;
  const int factor = opt.factor <= 0 ? 1 : opt.factor;

  double angle = 0;
  try {
    angle = root.get<double>("camera_angle_x");
  } catch (const pt::ptree_error&) {
    throw Error(json.string() + ": no numeric camera_angle_x");
  }
  if (!std::isfinite(angle) || angle <= 0 || angle >= 3.14)
    throw Error(json.string() + ": camera_angle_x " + std::to_string(angle) + " is not in (0, pi)");
  const auto frames = root.get_child_optional("frames");
  if (!frames || frames->empty()) throw Error(json.string() + ": no frames");

  size_t with_time = 0, index = 0;
  int w = 0, h = 0;
  for (const auto& [key, fr] : *frames) {
    (void)key;
    const std::string where = json.string() + ": frame " + std::to_string(index);
    Frame f;
    std::string file = fr.get<std::string>("file_path", "");
    if (file.empty()) throw Error(where + " has no file_path");
    fs::path img = dir / file;
    if (img.extension().empty()) img += ".png";
    f.name = img.lexically_normal().string();
    f.rgb = read_rgb(img.string(), opt.white_background);
    if (factor > 1) f.rgb = resize_area(f.rgb, f.rgb.width / factor, f.rgb.height / factor);
    if (index == 0) {
      w = f.rgb.width;
      h = f.rgb.height;
    } else if (f.rgb.width != w || f.rgb.height != h) {
      throw Error(img.string() + ": size differs from the first frame's");
    }
    const auto m = fr.get_child_optional("transform_matrix");
    if (!m || m->size() != 4) throw Error(where + ": transform_matrix must be 4x4");
    int r = 0;
    for (const auto& [rk, row] : *m) {
      (void)rk;
      if (row.size() != 4) throw Error(where + ": transform_matrix must be 4x4");
      int c = 0;
      for (const auto& [ck, v] : row) {
        (void)ck;
        double x = 0;
        try {
          x = v.get_value<double>();
        } catch (const pt::ptree_error&) {
          throw Error(where + ": transform_matrix holds a non-number");
        }
        if (!std::isfinite(x)) throw Error(where + ": transform_matrix holds NaN or Inf");
        if (r < 3) f.camera.c2w[r * 4 + c] = x;
        ++c;
      }
      ++r;
    }
    if (const auto t = fr.get_optional<double>("time")) {
      if (!std::isfinite(*t)) throw Error(where + ": time is not finite");
      f.time = 2.0 * *t - 1.0;
      ++with_time;
    }
    f.near = scene.near;
    f.far = scene.far;
    scene.frames.push_back(std::move(f));
    ++index;
  }
  if (with_time != 0 && with_time != scene.frames.size())
    throw Error(json.string() + ": only " + std::to_string(with_time) + " of " +
                std::to_string(scene.frames.size()) + " frames have a time");
  scene.has_time = with_time > 0;
  if (!scene.has_time)
    for (size_t i = 0; i < scene.frames.size(); ++i)
      scene.frames[i].time = frame_time(int(i), int(scene.frames.size()));
  const double focal = 0.5 * w / std::tan(0.5 * angle);
  for (auto& f : scene.frames) {
    f.camera.width = w;
    f.camera.height = h;
    f.camera.fx = f.camera.fy = focal;
    f.camera.cx = 0.5 * w;
    f.camera.cy = 0.5 * h;
    f.masks.push_back(Image8(w, h, 1, 255));
  }
  scene.notes.push_back(json.filename().string() + ": " + std::to_string(scene.frames.size()) +
                        " frames at " + std::to_string(w) + "x" + std::to_string(h) +
                        (factor > 1 ? " (downscaled by " + std::to_string(factor) + ")" : ""));
  scene.notes.push_back(scene.has_time ? "time per frame: yes (D-NeRF), mapped to 2 t - 1"
                                       : "time per frame: no (static scene)");
  scene.notes.push_back(std::string("RGBA composited on ") +
                        (opt.white_background ? "white" : "nothing (alpha dropped)") +
                        "; near 2, far 6; no NDC; static-only (K = 0)");
  return scene;
}

}  // namespace nova

// Blender / D-NeRF transforms_<split>.json reader: camera_angle_x, frames with file_path and a
// 4x4 camera-to-world transform_matrix (already OpenGL axes), and `time` in [0, 1] for D-NeRF.
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "data/fs_util.hpp"
#include "nova/runtime/error.hpp"
#include "nova/io/image_io.hpp"
#include "nova/data/scene_io.hpp"
#include "runtime/read_file.hpp"

namespace nova {

namespace fs = data::fs;
using json = nlohmann::json;

namespace {

// The file's JSON; Error "FILE:LINE: bad JSON (WHAT)" naming the line of the first error.
json read_json(const fs::path& file) {
  const std::optional<std::string> text = read_file(file.string());
  if (!text) throw Error(file.string() + ":0: bad JSON (cannot open file)");
  try {
    return json::parse(*text);
  } catch (const json::parse_error& e) {
    // e.byte: where the error was found, counted from 1.
    const size_t at = std::min<size_t>(e.byte > 0 ? e.byte - 1 : 0, text->size());
    const long line = 1 + std::count(text->begin(), text->begin() + static_cast<long>(at), '\n');
    // what(): "[json.exception.parse_error.101] parse error at line L, column C: WHAT".
    std::string what = e.what();
    const size_t column = what.find(", column ");
    const size_t colon = column == std::string::npos ? std::string::npos : what.find(": ", column);
    if (colon != std::string::npos) what = what.substr(colon + 2);
    throw Error(file.string() + ":" + std::to_string(line) + ": bad JSON (" + what + ")");
  }
}

}  // namespace

Scene load_blender_scene(const std::string& dir_s, const LoadOptions& opt) {
  const fs::path dir(dir_s);
  const fs::path json_path = dir / ("transforms_" + opt.split + ".json");
  if (!fs::exists(json_path)) throw Error(json_path.string() + ": missing");
  const json root = read_json(json_path);
  Scene scene;
  scene.name = fs::absolute(dir).lexically_normal().filename().string();
  scene.source = dir.string();
  scene.format = "blender";
  scene.near = 2;
  scene.far = 6;
  const int factor = opt.factor <= 0 ? 1 : opt.factor;

  const auto angle_at = root.is_object() ? root.find("camera_angle_x") : root.end();
  if (angle_at == root.end() || !angle_at->is_number()) throw Error(json_path.string() + ": no numeric camera_angle_x");
  const double angle = angle_at->get<double>();
  if (!std::isfinite(angle) || angle <= 0 || angle >= 3.14)
    throw Error(json_path.string() + ": camera_angle_x " + std::to_string(angle) + " is not in (0, pi)");
  const auto frames = root.find("frames");
  if (frames == root.end() || !frames->is_array() || frames->empty()) throw Error(json_path.string() + ": no frames");

  size_t with_time = 0, index = 0, with_alpha = 0;
  int w = 0, h = 0;
  for (const json& fr : *frames) {
    const std::string where = json_path.string() + ": frame " + std::to_string(index);
    Frame f;
    const auto file_at = fr.is_object() ? fr.find("file_path") : fr.end();
    const std::string file = file_at != fr.end() && file_at->is_string() ? file_at->get<std::string>() : "";
    if (file.empty()) throw Error(where + " has no file_path");
    fs::path img = dir / file;
    if (img.extension().empty()) img += ".png";
    f.name = img.lexically_normal().string();
    bool alpha = false;
    f.rgb = read_rgb(img.string(), opt.white_background, &alpha);
    with_alpha += alpha;
    f.rgb = downscale_by(f.rgb, factor, img.string());
    if (index == 0) {
      w = f.rgb.width;
      h = f.rgb.height;
    } else if (f.rgb.width != w || f.rgb.height != h) {
      throw Error(img.string() + ": size " + std::to_string(f.rgb.width) + "x" + std::to_string(f.rgb.height) +
                  " differs from the first frame's " + std::to_string(w) + "x" + std::to_string(h));
    }
    const auto m = fr.find("transform_matrix");
    if (m == fr.end() || !m->is_array() || m->size() != 4) throw Error(where + ": transform_matrix must be 4x4");
    int r = 0;
    for (const json& row : *m) {
      if (!row.is_array() || row.size() != 4) throw Error(where + ": transform_matrix must be 4x4");
      int c = 0;
      for (const json& v : row) {
        if (!v.is_number()) throw Error(where + ": transform_matrix holds a non-number");
        const double x = v.get<double>();
        if (!std::isfinite(x)) throw Error(where + ": transform_matrix holds NaN or Inf");
        if (r < 3) f.camera.c2w[r * 4 + c] = x;
        ++c;
      }
      ++r;
    }
    if (const auto t = fr.find("time"); t != fr.end()) {
      if (!t->is_number()) throw Error(where + ": time " + t->dump() + " is not a number");
      const double time = t->get<double>();
      if (!std::isfinite(time)) throw Error(where + ": time is not finite");
      f.time = 2.0 * time - 1.0;
      ++with_time;
    }
    f.near = scene.near;
    f.far = scene.far;
    scene.frames.push_back(std::move(f));
    ++index;
  }
  if (with_time != 0 && with_time != scene.frames.size())
    throw Error(json_path.string() + ": only " + std::to_string(with_time) + " of " +
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
  scene.notes.push_back(json_path.filename().string() + ": " + std::to_string(scene.frames.size()) +
                        " frames at " + std::to_string(w) + "x" + std::to_string(h) +
                        (factor > 1 ? " (downscaled by " + std::to_string(factor) + ")" : ""));
  scene.notes.push_back(scene.has_time ? "time per frame: yes (D-NeRF), mapped to 2 t - 1"
                                       : "time per frame: no (static scene)");
  if (with_alpha)
    scene.notes.push_back(std::to_string(with_alpha) + " RGBA frame(s) composited on " +
                          (opt.white_background ? "white" : "nothing (alpha dropped)"));
  scene.notes.push_back("near 2, far 6; no NDC; static-only (K = 0)");
  if (fs::is_directory(dir / "motion_masks"))
    scene.notes.push_back("motion_masks/ ignored: a Blender/D-NeRF folder trains the static NeRF alone");
  return scene;
}

}  // namespace nova

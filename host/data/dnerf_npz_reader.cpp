// The "tiny D-NeRF" .npz (images float32 (N, H, W, 3) in [0, 1], poses float32 (N, 4, 4)
// camera-to-world in OpenGL axes, times float32 (N,) in [0, 1], focal scalar). Splits are not
// stored: `times` restart at 0 for each of train, val, test, in that order.
#include <algorithm>
#include <cmath>

#include "data/fs_util.hpp"
#include "io/zip.hpp"
#include "nova/runtime/error.hpp"
#include "nova/io/npy.hpp"
#include "nova/data/scene_io.hpp"

namespace nova {

namespace fs = data::fs;

Scene load_dnerf_npz_scene(const std::string& dir_s, const LoadOptions& opt) {
  const fs::path dir(dir_s);
  fs::path file = dir;
  if (fs::is_directory(dir)) {
    const auto found = data::list_files(dir, {".npz"});
    if (found.size() != 1)
      throw Error(dir_s + ": expected exactly one .npz file, found " + std::to_string(found.size()));
    file = found[0];
  }
  const auto members = io::read_zip(file.string());
  auto get = [&](const std::string& name) {
    const auto it = members.find(name + ".npy");
    if (it == members.end()) throw Error(file.string() + ": no '" + name + "' array");
    return parse_npy(it->second, file.string() + ":" + name + ".npy");
  };
  const NpyArray images = get("images"), poses = get("poses"), times = get("times"),
                 focal = get("focal");
  if (images.shape.size() != 4 || images.shape[3] != 3)
    throw Error(file.string() + ": images must be (N, H, W, 3)");
  const size_t n = images.shape[0], h = images.shape[1], w = images.shape[2];
  if (poses.shape != std::vector<size_t>{n, 4, 4})
    throw Error(file.string() + ": poses must be (N, 4, 4) with N = " + std::to_string(n));
  if (times.shape != std::vector<size_t>{n})
    throw Error(file.string() + ": times must be (N,) with N = " + std::to_string(n));
  if (focal.size() != 1 || !(focal.values[0] > 0))
    throw Error(file.string() + ": focal must be one positive number");
  for (double v : poses.values)
    if (!std::isfinite(v)) throw Error(file.string() + ": poses hold NaN or Inf");

  // Split boundaries where time drops back.
  std::vector<size_t> starts = {0};
  for (size_t i = 1; i < n; ++i)
    if (times.values[i] < times.values[i - 1]) starts.push_back(i);
  starts.push_back(n);
  const std::vector<std::string> names = {"train", "val", "test"};
  size_t split = 0;
  while (split < names.size() && names[split] != opt.split) ++split;
  if (split >= names.size() || split + 1 >= starts.size())
    throw Error(file.string() + ": no '" + opt.split + "' split (found " +
                std::to_string(starts.size() - 1) + " time sequences: train, val, test)");

  Scene s;
  s.name = fs::absolute(dir).lexically_normal().filename().string();
  s.source = dir_s;
  s.format = "dnerf-npz";
  s.near = 2;
  s.far = 6;
  for (size_t i = starts[split]; i < starts[split + 1]; ++i) {
    Frame f;
    f.name = "images[" + std::to_string(i) + "]";
    f.rgb = Image8(int(w), int(h), 3);
    const double* src = &images.values[i * h * w * 3];
    for (size_t p = 0; p < h * w * 3; ++p)
      f.rgb.data[p] = static_cast<uint8_t>(std::lround(std::clamp(src[p], 0.0, 1.0) * 255.0));
    f.camera.width = int(w);
    f.camera.height = int(h);
    f.camera.fx = f.camera.fy = focal.values[0];
    f.camera.cx = 0.5 * w;
    f.camera.cy = 0.5 * h;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c) f.camera.c2w[r * 4 + c] = poses.values[i * 16 + r * 4 + c];
    f.time = 2.0 * times.values[i] - 1.0;
    f.near = 2;
    f.far = 6;
    f.masks.push_back(Image8(int(w), int(h), 1, 255));
    s.frames.push_back(std::move(f));
  }
  s.notes.push_back(file.filename().string() + ": split '" + opt.split + "' = frames " +
                    std::to_string(starts[split]) + ".." + std::to_string(starts[split + 1] - 1) +
                    " of " + std::to_string(n) + " (splits found from time resets)");
  s.notes.push_back("time per frame: yes, mapped to 2 t - 1; black background (alpha dropped "
                    "when packed); near 2, far 6; no NDC; static-only (K = 0)");
  return s;
}

}  // namespace nova

// Writes a synthetic scene in the NOVA layout with its ground truth (see synth.hpp).
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "data/fs_util.hpp"
#include "nova/runtime/error.hpp"
#include "nova/io/compose_spec_text.hpp"
#include "nova/io/image_io.hpp"
#include "nova/io/npy.hpp"
#include "nova/data/scene_io.hpp"
#include "nova/data/synth.hpp"

namespace nova {
namespace {

namespace fs = data::fs;

std::string frame_name(int i) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%03d", i);
  return buf;
}

void write_text(const fs::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  if (!out) throw Error(p.string() + ": cannot create");
  out << text;
  if (!out) throw Error(p.string() + ": write failed");
}

// Depth bounds of a render (min / max over hit pixels), as poses_bounds stores them.
std::array<double, 2> bounds_of(const ImageF& depth) {
  double lo = 1e300, hi = 0;
  for (float z : depth.data)
    if (z > 0) {
      lo = std::min(lo, double(z));
      hi = std::max(hi, double(z));
    }
  return {lo, hi};
}

void append_row(std::vector<double>& rows, const Camera& c, std::array<double, 2> b) {
  const auto block = gl_to_llff_block(c.c2w, c.height, c.width, c.fx);
  rows.insert(rows.end(), block.begin(), block.end());
  rows.push_back(b[0]);
  rows.push_back(b[1]);
}

ImageF inverse_depth(const ImageF& depth) {
  ImageF d = depth;
  for (float& v : d.data) v = v > 0 ? 1.0f / v : 0.0f;
  return d;
}

// The instance map of a spec (processed frame) expressed in the raw world:
// M_raw = A^-1 M A, with A(p) = scale * Rc p + tc (Rc, tc: the recentring map).
Pose34 raw_instance_map(const ComposeInstance& inst, const WorldTransform& a) {
  const Pose34 m = instance_transform(inst);
  Pose34 s{a.scale, 0, 0, 0, 0, a.scale, 0, 0, 0, 0, a.scale, 0};  // scale as a "pose"
  // A = recenter * S; A^-1 = S^-1 * recenter^-1. Compose as 3x4 affine maps.
  const Pose34 a_map = pose_multiply(a.recenter, s);
  Pose34 s_inv{1 / a.scale, 0, 0, 0, 0, 1 / a.scale, 0, 0, 0, 0, 1 / a.scale, 0};
  const Pose34 a_inv = pose_multiply(s_inv, pose_inverse(a.recenter));
  return pose_multiply(a_inv, pose_multiply(m, a_map));
}

// The composition targets of the preset, written in the processed frame: translations are
// given in raw units and mapped, pivots are the objects' centres.
ComposeSpec make_spec(const SynthWorld& w, const WorldTransform& a) {
  const int n = w.preset().frames, k_objects = w.objects();
  auto centre = [&](int obj, double t) {
    const Pose34 p = w.object_pose(obj, t);
    return a.apply_point({p[3], p[7], p[11]});
  };
  auto raw_offset = [&](std::array<double, 3> t) {
    auto d = a.apply_direction(t);
    for (auto& v : d) v *= a.scale;
    return d;
  };
  ComposeSpec spec;
  const double t0 = frame_time(0, n), tm = frame_time(n / 2, n), tq = frame_time(n / 4, n),
               tl = frame_time(n - 1, n);
  {
    ComposeTarget t{"object1_moved", 0, true, {}};
    ComposeInstance i{1, t0, {0, 0, 0}, raw_offset(w.scene().compose_shift), centre(1, t0)};
    t.instances.push_back(i);
    for (int k = 2; k <= k_objects; ++k) t.instances.push_back({k, t0, {0, 0, 0}, {0, 0, 0}, centre(k, t0)});
    spec.targets.push_back(t);
  }
  {
    // The last object turned about its own centre, alone in the background.
    ComposeTarget t{"object" + std::to_string(k_objects) + "_rotated", n / 2, true, {}};
    t.instances.push_back({k_objects, tq, {0, 45, 0}, {0, 0, 0}, centre(k_objects, tq)});
    spec.targets.push_back(t);
  }
  {
    ComposeTarget t{"two_copies", 0, true, {}};
    t.instances.push_back({1, t0, {0, 0, 0}, {0, 0, 0}, centre(1, t0)});
    t.instances.push_back({1, tm, {0, 0, 0}, raw_offset(w.scene().compose_copy_shift), centre(1, tm)});
    if (k_objects >= 2) t.instances.push_back({2, tl, {20, 0, 10}, {0, 0, 0}, centre(2, tl)});
    spec.targets.push_back(t);
  }
  {
    ComposeTarget t{"objects_only", n - 1, false, {}};
    for (int k = 1; k <= k_objects; ++k) t.instances.push_back({k, tl, {0, 0, 0}, {0, 0, 0}, centre(k, tl)});
    spec.targets.push_back(t);
  }
  return spec;
}

}  // namespace

std::string write_synthetic_scene(const std::string& out_dir, const std::string& preset,
                                  uint32_t seed, bool replace) {
  const SynthWorld world(preset, seed);
  const SynthPreset& p = world.preset();
  const int n = p.frames;
  data::StagedDir staged(out_dir, replace);
  const fs::path root = staged.path();
  for (const char* d : {"images", "disp", "motion_masks", "gt", "gt/cam0", "gt/compose"})
    fs::create_directories(root / d);
  const int k_objects = world.objects();
  const SynthImperfections& imp = world.scene().imperfections;
  for (int k = 0; k <= k_objects; ++k)
    fs::create_directories(root / "motion_masks" / std::to_string(k));

  // Training frames: the inputs carry the scene's imperfections; depth bounds stay exact.
  std::vector<double> rows;
  std::vector<Pose34> raw;
  std::vector<double> nears;
  for (int i = 0; i < n; ++i) {
    const Camera cam = world.camera(i);
    const SynthRender r = world.render(cam, frame_time(i, n));
    const std::string name = frame_name(i);
    write_png((root / "images" / (name + ".png")).string(), synth_training_image(r.rgb, imp, i));
    const std::vector<Image8> masks = synth_training_masks(r.masks, imp, i);
    for (int k = 0; k <= k_objects; ++k)
      write_png((root / "motion_masks" / std::to_string(k) / (name + ".png")).string(), masks[size_t(k)]);
    const ImageF disp = synth_training_disparity(inverse_depth(r.depth), imp);
    write_npy_f32((root / "disp" / (name + ".npy")).string(),
                  {size_t(disp.height), size_t(disp.width)}, disp.data);
    const auto b = bounds_of(r.depth);
    append_row(rows, cam, b);
    raw.push_back(cam.c2w);
    nears.push_back(b[0]);
  }
  write_npy_f64((root / "poses_bounds.npy").string(), {size_t(n), 17}, rows);

  // Ground truth: camera 0 at every time, then each held-out camera at every time.
  std::vector<double> gt_rows;
  std::string views =
      "# nova synthetic ground truth: IMAGE KIND TIME_INDEX; row r of gt/poses_bounds.npy is\n"
      "# the camera of the r-th view (LLFF layout, processed like the training poses)\n";
  auto add_views = [&](const Camera& cam, const std::string& folder, const std::string& kind) {
    fs::create_directories(root / "gt" / folder);
    for (int i = 0; i < n; ++i) {
      const SynthRender r = world.render(cam, frame_time(i, n));
      const std::string rel = folder + "/" + frame_name(i) + ".png";
      write_png((root / "gt" / rel).string(), r.rgb);
      // The exact objects region, so that nova eval scores objects and background apart.
      if (r.masks.size() > 1) write_png((root / "gt" / ground_truth_objects_name(rel)).string(), objects_region(r.masks));
      append_row(gt_rows, cam, bounds_of(r.depth));
      views += rel + " " + kind + " " + std::to_string(i) + "\n";
    }
  };
  add_views(world.camera(0), "cam0", "cam0");
  for (int h = 1; h <= p.heldout_cameras; ++h)
    add_views(world.heldout_camera(h), "heldout" + std::to_string(h), "heldout");
  write_npy_f64((root / "gt" / "poses_bounds.npy").string(), {gt_rows.size() / 17, 17}, gt_rows);
  write_text(root / "gt" / "views.txt", views);

  // Composition targets, rendered from the spec text itself (parsed back), so the file and
  // the images cannot disagree.
  const WorldTransform a = llff_world_transform(raw, nears, 0.9);
  const std::string spec_text = format_compose_spec(make_spec(world, a));
  const fs::path spec_path = root / "gt" / "compose" / "spec.txt";
  write_text(spec_path, spec_text);
  const ComposeSpec spec = parse_compose_spec(spec_text, spec_path.string());
  for (const auto& t : spec.targets) {
    std::vector<SynthInstance> inst;
    for (const auto& i : t.instances)
      inst.push_back({i.object, pose_multiply(raw_instance_map(i, a), world.object_pose(i.object, i.time)),
                      world.object_stretch(i.object, i.time)});
    const SynthRender r = world.render_instances(world.camera(t.camera), t.background, inst);
    const std::string rel = "compose/" + t.name + ".png";
    write_png((root / "gt" / rel).string(), r.rgb);
    if (r.masks.size() > 1) write_png((root / "gt" / ground_truth_objects_name(rel)).string(), objects_region(r.masks));
  }

  std::ostringstream info;
  info << "nova synthetic scene\npreset " << p.name << "\nseed " << seed << "\nframes " << n
       << "\nsize " << p.width << "x" << p.height << "\nfocal " << p.focal
       << "\nobjects " << k_objects
       << "\ntime frame i of N: t = 2 i / N - 1\n";
  // The fixed presets' synth.txt stays as it always was; a family scene says what was drawn.
  if (synth_preset_drawn(p.name)) info << describe_synth_scene(world.scene());
  write_text(root / "synth.txt", info.str());
  staged.commit();

  std::ostringstream rep;
  rep << "wrote " << out_dir << ": " << n << " frames at " << p.width << "x" << p.height << ", "
      << k_objects << " objects, " << n * (1 + p.heldout_cameras)
      << " ground-truth views, " << spec.targets.size() << " composition targets";
  return rep.str();
}

}  // namespace nova

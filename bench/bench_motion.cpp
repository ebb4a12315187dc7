// `nova-bench motion`: the rigid objects' starting motion (track_object, motion_alignment.hpp, as
// initial_motion chains it) against the synthetic family's exact object poses. Per seed and
// object: the true turn per frame, the found turn's error per frame pair (mean, worst) and the
// drift of the chained turn by the last frame that shows the object. Depth is the disparity
// placed by fit_disparity (what training uses) or, with --exact-depth, the renders' own
// depth: the gap between the two says how much of the error is the disparity's. With --runs
// DIR (nova-bench accuracy's OUT/runs: DIR/family-S/checkpoint.bin) also the trained
// trajectory's turns, scored the same way: whether joint training mends the start.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <optional>

#include "bench.hpp"
#include "family_truth.hpp"
#include "options.hpp"
#include "nova/sampling/camera.hpp"
#include "nova/train/disparity_edges.hpp"
#include "nova/train/disparity_fit.hpp"
#include "nova/data/scene_io.hpp"
#include "nova/data/synth.hpp"
#include "nova/masks/motion_masks.hpp"
#include "nova/model/checkpoint.hpp"
#include "nova/runtime/error.hpp"
#include "nova/sampling/rigid_motion.hpp"
#include "nova/train/motion_alignment.hpp"
#include "nova/train/motion_init.hpp"

namespace nova::bench {
namespace {

Vec3 centroid_at_median_depth(const Frame& f, const ImageF& depth, const Image8& mask) {
  double cx = 0, cy = 0, n = 0;
  std::vector<float> z;
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x)
      if (mask.at(x, y) >= 128) {
        cx += x, cy += y, n += 1;
        z.push_back(depth.data[size_t(y) * depth.width + x]);
      }
  std::nth_element(z.begin(), z.begin() + long(z.size() / 2), z.end());
  return camera_unproject(f.camera, cx / n, cy / n, z[z.size() / 2]);
}

int mask_pixels(const Image8& m) {
  return int(std::count_if(m.data.begin(), m.data.end(), [](uint8_t v) { return v >= 128; }));
}

struct ObjectScore {
  int seed = 0, object = 0, pairs = 0;
  double true_turn = 0, mean_error = 0, worst_error = 0, drift = 0, chained_truth = 0;
  // The trained trajectory's (with --runs): error per frame pair, drift by the last frame.
  double trained_error = -1, trained_drift = -1;
  // Where a frame pair's motion carries the object's true centre, off the true centre of the
  // second frame, in the object's radii (mean over pairs): the start's and the trained one's.
  double shift = 0, trained_shift = -1;
  // The object's longest axis carried from the first frame by the start's poses, off the true
  // axis (degrees, as lines, mean over the later frames): what a rod's silhouette shows.
  double axis = 0;
  // Each anchor's depth from its frame's camera over the true centre's (mean over the frames):
  // how far the disparity places the object.
  double depth_ratio = 0;
};

// Object k's turn from frame a to frame b in a trained trajectory [K, F, 6]: a world point of
// frame a maps to the canonical y = R_a (x - tau_a) + q and back to frame b's world as
// R_b^T (y - q) + tau_b, a turn of R_b^T R_a.
Mat3 trained_turn(const std::vector<float>& rows, int frames, int k, int a, int b) {
  const float* m = &rows[size_t(k - 1) * size_t(frames) * 6];
  const auto angles = [&](int i) { return Vec3{m[i * 6], m[i * 6 + 1], m[i * 6 + 2]}; };
  return multiply(transpose(euler_xyz_to_matrix(angles(b))), euler_xyz_to_matrix(angles(a)));
}

double distance(const Vec3& a, const Vec3& b) { return std::hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]); }

// A world point of frame a carried to frame b by a trained trajectory: into the canonical
// space at a's time, out of it at b's.
Vec3 trained_carry(const std::vector<float>& rows, int frames, int k, int a, int b, const Vec3& x) {
  const float* m = &rows[size_t(k - 1) * size_t(frames) * 6];
  const Vec3 canonical = motion_to_canonical(m, frames, frame_time(a, frames), x);
  return apply_rigid(invert_rigid(motion_matrix(m, frames, frame_time(b, frames))), canonical);
}

std::vector<ObjectScore> score_seed(int seed, const std::string& dir, bool exact_depth, const std::string& run,
                                   const AlignmentOptions& options) {
  const Scene scene = load_scene(dir);
  const SynthWorld world("family", uint32_t(seed));
  const int F = int(scene.frames.size());
  const std::vector<int> scene_object = match_objects(scene, world);
  const LoadedWorld loaded_frame = loaded_world(scene, world);
  const Mat3& Rc = loaded_frame.turn;
  const double scale = loaded_frame.scale;
  const DisparityFit fit = fit_disparity(scene);
  std::vector<ImageF> depth(static_cast<size_t>(F));
  for (int i = 0; i < F; ++i) {
    const Frame& f = scene.frames[size_t(i)];
    ImageF& d = depth[size_t(i)];
    d.width = f.rgb.width;
    d.height = f.rgb.height;
    d.data.assign(size_t(d.width) * d.height, 0.0f);
    if (exact_depth) {
      const SynthRender r = world.render(world.camera(i), frame_time(i, F));
      for (size_t p = 0; p < d.data.size(); ++p) d.data[p] = float(r.depth.data[p] * scale);
    } else if (fit.ok) {
      for (size_t p = 0; p < d.data.size(); ++p) {
        const double w = fit.inverse_depth(f.disparity.data[p]);
        if (w > 0 && std::isfinite(w)) d.data[p] = float(1 / w);
      }
    }
  }
  const Mat34& loaded = loaded_frame.point;
  const auto true_centre = [&](int k, int i) {
    const Pose34 p = world.object_pose(k, frame_time(i, F));
    return apply_rigid(loaded, {p[3], p[7], p[11]});
  };
  auto true_turn = [&](int k, int a, int b) {  // object k's turn from frame a to b, loaded world
    const Mat3 r = multiply(rotation_of(world.object_pose(k, frame_time(b, F))),
                            transpose(rotation_of(world.object_pose(k, frame_time(a, F)))));
    return multiply(Rc, multiply(r, transpose(Rc)));
  };
  std::vector<float> trained;
  if (!run.empty()) {
    const Checkpoint checkpoint = read_checkpoint(run + "/checkpoint.bin");
    trained = checkpoint.array("objects.motion").values;
    if (trained.size() != size_t(world.objects()) * size_t(F) * 6)
      throw Error("nova-bench motion: " + run + "'s objects.motion holds " + std::to_string(trained.size()) +
                  " numbers, not " + std::to_string(world.objects()) + " objects x " + std::to_string(F) + " frames x 6");
  }
  std::vector<ObjectScore> out;
  for (int k = 1; k <= world.objects(); ++k) {
    ObjectScore s;
    s.seed = seed;
    s.object = k;
    const double radius = scale * synth_bounding_radius(world.scene().objects[size_t(k - 1)].shape);
    std::vector<int> seen;
    const size_t m = size_t(scene_object[size_t(k)]);  // its masks in the scene
    for (int i = 0; i < F; ++i)
      if (mask_pixels(scene.frames[size_t(i)].masks.at(m)) >= 8) seen.push_back(i);
    std::vector<ObjectView> views;
    std::vector<Vec3> anchors;
    for (int i : seen) {
      const Frame& f = scene.frames[size_t(i)];
      views.push_back({&f.camera, &f.rgb, &f.masks.at(m), &depth[size_t(i)]});
      anchors.push_back(centroid_at_median_depth(f, depth[size_t(i)], f.masks.at(m)));
    }
    {  // the frames initial_motion leaves out: anchors off the object's path
      std::vector<double> radii;
      for (size_t j = 0; j < seen.size(); ++j)
        radii.push_back(mask_radius(scene.frames[size_t(seen[j])].masks.at(m), scene.frames[size_t(seen[j])].camera, anchors[j]));
      const std::vector<size_t> dropped = off_path_anchors(anchors, seen, radii);
      for (auto j = dropped.rbegin(); j != dropped.rend(); ++j) {
        seen.erase(seen.begin() + long(*j));
        views.erase(views.begin() + long(*j));
        anchors.erase(anchors.begin() + long(*j));
      }
    }
    for (size_t j = 0; j < seen.size(); ++j) {
      const Camera& c = scene.frames[size_t(seen[j])].camera;
      s.depth_ratio += camera_project(c, anchors[j])[2] / camera_project(c, true_centre(k, seen[j]))[2] / double(seen.size());
    }
    const std::vector<Mat34> poses = track_object(views, anchors, options);
    for (size_t j = 1; j < seen.size(); ++j) {
      const int a = seen[j - 1], b = seen[j];
      const Mat3 found = multiply(rotation_of(poses[j]), transpose(rotation_of(poses[j - 1])));
      const Mat3 truth = true_turn(k, a, b);
      const double e = turn_degrees(multiply(found, transpose(truth)));
      s.true_turn += turn_degrees(truth) / (b - a);
      s.mean_error += e;
      s.worst_error = std::max(s.worst_error, e);
      // P_b P_a^-1 carries frame a's point to frame b.
      s.shift += distance(apply_rigid(poses[j], apply_rigid(invert_rigid(poses[j - 1]), true_centre(k, a))),
                          true_centre(k, b)) / radius;
      ++s.pairs;
    }
    {
      const SynthVec& size = world.scene().objects[size_t(k - 1)].shape.size;
      const size_t longest = size_t(std::max_element(size.begin(), size.end()) - size.begin());
      const auto true_axis = [&](int i) {  // the loaded world's direction of the longest axis at frame i
        const Mat3 r = multiply(Rc, rotation_of(world.object_pose(k, frame_time(i, F))));
        return Vec3{r[longest], r[3 + longest], r[6 + longest]};
      };
      const Vec3 first = true_axis(seen.empty() ? 0 : seen.front());
      for (size_t j = 1; j < seen.size(); ++j) {
        const Mat3 carry = multiply(rotation_of(poses[j]), transpose(rotation_of(poses.front())));
        const Vec3 found{carry[0] * first[0] + carry[1] * first[1] + carry[2] * first[2],
                         carry[3] * first[0] + carry[4] * first[1] + carry[5] * first[2],
                         carry[6] * first[0] + carry[7] * first[1] + carry[8] * first[2]};
        const Vec3 truth = true_axis(seen[j]);
        const double c = std::fabs(found[0] * truth[0] + found[1] * truth[1] + found[2] * truth[2]);
        s.axis += std::acos(std::min(1.0, c)) * 180.0 / 3.14159265358979323846 / double(seen.size() - 1);
      }
    }
    const Mat3 chain = seen.empty() ? Mat3{1, 0, 0, 0, 1, 0, 0, 0, 1}
                                    : multiply(rotation_of(poses.back()), transpose(rotation_of(poses.front())));
    if (!trained.empty() && seen.size() > 1) {
      s.trained_error = s.trained_drift = s.trained_shift = 0;
      for (size_t j = 1; j < seen.size(); ++j) {
        s.trained_error += turn_degrees(multiply(trained_turn(trained, F, k, seen[j - 1], seen[j]), transpose(true_turn(k, seen[j - 1], seen[j]))));
        s.trained_shift += distance(trained_carry(trained, F, k, seen[j - 1], seen[j], true_centre(k, seen[j - 1])),
                                    true_centre(k, seen[j])) / radius;
      }
      s.trained_error /= double(seen.size() - 1);
      s.trained_shift /= double(seen.size() - 1);
      s.trained_drift = turn_degrees(multiply(trained_turn(trained, F, k, seen.front(), seen.back()),
                                         transpose(true_turn(k, seen.front(), seen.back()))));
    }
    if (s.pairs > 0) {
      s.true_turn /= s.pairs;
      s.mean_error /= s.pairs;
      s.shift /= s.pairs;
      const Mat3 whole = true_turn(k, seen.front(), seen.back());
      s.drift = turn_degrees(multiply(chain, transpose(whole)));
      s.chained_truth = turn_degrees(whole);
    }
    out.push_back(s);
  }
  return out;
}

}  // namespace

int motion(const Args& args) {
  const Options o(args, {{"seeds", "1,2,3,4"}, {"exact-depth", "off"}, {"runs", ""}, {"window", std::to_string(AlignmentOptions{}.window)}, {"edge", std::to_string(AlignmentOptions{}.edge_px)}, {"depth-reach", "0"}, {"consistency", "0"}, {"depth-auto", "off"}, {"made-masks", "off"}, {"silhouette", "off"}, {"bridge", "0"}});
  if (o.help()) {
    std::cout << o.usage("motion") << "\n--seeds: family seeds; --exact-depth: place the objects' pixels at the "
                 "renders' exact depth instead of the fitted disparity; --runs DIR: also score the trained "
                 "trajectories of DIR/family-S (nova-bench accuracy's OUT/runs); --window N: earlier frames each frame "
                 "is aligned to at once; --edge PX: pixels of each mask's rim left out; --depth-reach PX: each mask pixel's "
                 "depth the nearest of the mask's within PX pixels at 160 px width (nova train --align-depth-reach; "
                 "default 0: as given); --consistency R: a frame pair whose turn the way back does not undo within R of it takes no turn "
                 "(nova train --align-consistency; default 0: no check); --depth-auto: depth-reach 1 where the scene's "
                 "step share (the column) is under 0.7, as nova train --align-depth-auto; --made-masks: track the objects "
                 "in the masks nova masks makes instead of the given ones (each true object by the made one that "
                 "shares the most pixels with it); --silhouette: a pair too thin to align by its interior turns as its "
                 "masks' principal axes do instead of not at all (nova train --align-silhouette true); --bridge R: a pair "
                 "left with more than R times the median pair's residual, or too few points to align, between two that "
                 "aligned well, takes their interpolated turn (nova train --align-bridge; default 0: its own)\n";
    return 0;
  }
  const std::string runs = o.str("runs");
  AlignmentOptions options;
  options.window = static_cast<int>(o.integer("window"));
  if (options.window < 1) throw Error("option 'window' must be at least 1, not " + o.str("window"));
  options.edge_px = static_cast<int>(o.integer("edge"));
  if (options.edge_px < 1) throw Error("option 'edge' must be at least 1, not " + o.str("edge"));
  // A number in [0, high].
  const auto number = [&](const char* key, double high, double& value) {
    const std::string v = o.str(key);
    char* end = nullptr;
    value = std::strtod(v.c_str(), &end);
    if (v.empty() || *end || !(value >= 0) || value > high)
      throw Error(std::string("option '") + key + "' must be a number in [0, " + std::to_string(static_cast<int>(high)) +
                  "], not '" + v + "'");
  };
  number("depth-reach", 64, options.depth_reach_px);
  number("consistency", 100, options.consistency);
  number("bridge", 1000, options.bridge_ratio);
  options.silhouette_turns = o.flag("silhouette");
  ScratchDir scratch("motion");
  std::printf("%5s %7s %6s %12s %11s %11s %18s %8s", "seed", "object", "pairs", "true deg/fr", "error mean",
              "error worst", "drift / whole turn", "seconds");
  std::printf(" %6s %10s %9s %6s", "shift", "step share", "axis err", "depth");
  if (!runs.empty()) std::printf(" %13s %13s %7s", "trained error", "trained drift", "t.shift");
  std::printf("\n");
  double sum_error = 0, sum_drift = 0, sum_trained_error = 0, sum_trained_drift = 0;
  int objects = 0;
  for (long seed : o.integers("seeds")) {
    const auto dir = scratch / ("family" + std::to_string(seed));
    write_synthetic_scene(dir.string(), "family", uint32_t(seed));
    if (o.flag("made-masks")) {
      LoadOptions load;
      load.static_only = true;
      load.load_gt = false;
      const Scene given = load_scene(dir.string(), load);
      write_motion_masks(given, make_motion_masks(given), (dir / "motion_masks").string(), true);
    }
    // The share of the disparity's step at the silhouettes (disparity_edges.hpp), and with
    // --depth-auto the reach training's align-depth-auto takes from it.
    const std::optional<double> share = silhouette_step_share(load_scene(dir.string()));
    AlignmentOptions seed_options = options;
    if (o.flag("depth-auto") && seed_options.depth_reach_px == 0 && share && *share < kBlurredStepShare)
      seed_options.depth_reach_px = 1;
    const auto t0 = std::chrono::steady_clock::now();
    const std::string run = runs.empty() ? "" : runs + "/family-" + std::to_string(seed);
    const std::vector<ObjectScore> scores = score_seed(int(seed), dir.string(), o.flag("exact-depth"), run, seed_options);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    for (const ObjectScore& s : scores) {
      std::printf("%5d %7d %6d %12.2f %11.2f %11.2f %8.1f / %7.1f %8.1f", s.seed, s.object, s.pairs, s.true_turn,
                  s.mean_error, s.worst_error, s.drift, s.chained_truth, seconds);
      std::printf(" %6.2f %10s %9.1f %6.2f", s.shift, share ? std::to_string(*share).substr(0, 4).c_str() : "-", s.axis, s.depth_ratio);
      if (!runs.empty()) std::printf(" %13.2f %13.1f %7.2f", s.trained_error, s.trained_drift, s.trained_shift);
      std::printf("\n");
      if (s.pairs == 0) continue;
      sum_error += s.mean_error;
      sum_drift += s.drift;
      sum_trained_error += s.trained_error;
      sum_trained_drift += s.trained_drift;
      ++objects;
    }
  }
  if (objects > 0) {
    std::printf("mean over %d objects: error %.2f degrees per frame pair, drift %.1f degrees", objects,
                sum_error / objects, sum_drift / objects);
    if (!runs.empty())
      std::printf("; trained: error %.2f, drift %.1f", sum_trained_error / objects, sum_trained_drift / objects);
    std::printf("\n");
  }
  return 0;
}

}  // namespace nova::bench

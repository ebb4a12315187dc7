// The trainer end to end on the tiny synthetic scene: it learns (beats the best constant
// image on held-out views), a resumed run is bit-identical to a straight one, and
// checkpoints written for other networks are refused.
#include <boost/test/unit_test.hpp>
#include <algorithm>
#include <cmath>
#include <cstring>

#include "harness.hpp"
#include "nova/metrics/image_metrics.hpp"
#include "nova/data/scene_io.hpp"
#include "nova/io/pictures.hpp"
#include "nova/model/field_graphs.hpp"
#include "nova/model/fields.hpp"
#include "nova/model/object_samples.hpp"
#include "nova/sampling/rigid_motion.hpp"
#include "nova/train/run_folder.hpp"
#include "nova/train/disparity_edges.hpp"
#include "nova/train/trainer.hpp"
#include "nova/model/view_renderer.hpp"
#include "scene_test_util.hpp"
#include "train/step_batch.hpp"

namespace nova::test {
namespace {

// Small enough for CI on PoCL (a few seconds), large enough to learn the tiny scene's layout.
// The frequency encoding learns the tiny scene's novel camera-0 views better in 400 steps
// (17.1 dB against 16.3 for a small hash grid); the hash grid (the quick preset's) runs the
// resume checks, whose table gradient must be as deterministic as the rest.
TrainConfig tiny_config(Encoding encoding) {
  TrainConfig c = preset_config("quick");
  c.field.encoding = encoding;
  c.field.hash.levels = 8;
  c.field.hash.log2_size = 12;
  c.field.hash.max_resolution = 64;
  c.field.depth = encoding == Encoding::HashGrid ? 2 : 3;
  c.field.width = encoding == Encoding::HashGrid ? 32 : 48;
  c.field.skip = -1;
  c.field.pos_freqs = 5;
  c.field.dir_freqs = 2;
  c.rays = 256;
  c.samples = 24;
  c.pretrain_steps = 100;
  c.steps = 300;
  c.lr = encoding == Encoding::HashGrid ? 1e-2f : 3e-3f;
  c.lr_decay_steps = 400;
  c.augment_start = 0;
  c.checkpoint_every = 100000;
  c.log_every = 20;
  // The learning floor was set without skipping; at quick's alpha 0.1 the grids switch on at
  // joint step 256 of 300 and the loss jumps while the model adapts (measured: the last joint
  // losses 0.33 against 0.27 allowed, 16.3 dB against a 16.5 dB floor). Skipping has its own
  // case below and the resume case turns it back on.
  c.occupancy = false;
  return c;
}

// tiny_config's networks for a run of a few steps.
TrainConfig short_config(int pretrain_steps, int steps, int rays, int samples) {
  TrainConfig c = tiny_config(Encoding::HashGrid);
  c.pretrain_steps = pretrain_steps;
  c.steps = steps;
  c.rays = rays;
  c.samples = samples;
  return c;
}

Scene tiny_scene() {
  LoadOptions o;
  o.load_gt = true;
  return load_scene(cached_tiny_scene().string(), o);
}

// The scene as trained seen from camera 0 at each ground-truth time (the eval protocol).
std::vector<ViewRequest> cam0_requests(const Scene& scene) {
  std::vector<ViewRequest> out;
  for (const GroundTruthView& v : scene.gt_views) {
    if (v.kind != "cam0") continue;
    ViewRequest req;
    req.camera = v.camera;
    req.instances = scene_instances(scene.num_objects, v.time);
    out.push_back(req);
  }
  return out;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// The checkpoint of `steps` steps of `c` on `scene` in a run folder of its own.
Checkpoint trained_for(const Scene& scene, const TrainConfig& c, long steps) {
  TempDir dir("trained_for");
  Trainer t(runtime(), scene, c, (dir / "run").string());
  t.run({}, steps);
  return t.checkpoint();
}

// Whether two checkpoints hold the same arrays, bit for bit.
bool same_parameters(const Checkpoint& a, const Checkpoint& b) {
  if (a.arrays.size() != b.arrays.size()) return false;
  for (size_t i = 0; i < a.arrays.size(); ++i)
    if (a.arrays[i].name != b.arrays[i].name || !same_bits(a.arrays[i].values, b.arrays[i].values)) return false;
  return true;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(train)

// Trains `c` on the tiny scene and checks that it learnt: the joint loss falls and camera 0
// scores above the best constant image.
void check_learns_the_tiny_scene(const TrainConfig& c) {
  const Scene scene = tiny_scene();
  TempDir dir("train");
  Trainer t(runtime(), scene, c, (dir / "run").string());
  std::vector<TrainProgress> log;
  t.run([&](const TrainProgress& p) { log.push_back(p); });
  BOOST_REQUIRE(log.size() >= 4);
  // Joint loss falls: single batches are noisy (128-ray regions, augmented views), so the
  // mean of the last two un-augmented records must be under 3/4 of the first two
  // (measured under OpenBLAS's default, Haswell, SkylakeX, Cooperlake and Zen kernels:
  // 0.50 of it with the paper's networks, 0.43 with rigid objects). The trajectory's
  // smoothness term is left out: it is a
  // prior on the rigid motion's start (about 1 on this 64 x 48 scene, whose alignment is
  // rough), not what the networks learn, and at lr-motion 0.1 it falls slowly.
  std::vector<double> joint;
  for (const auto& p : log) {
    if (p.phase != "joint" || p.augmented) continue;
    double smooth = 0;
    for (const auto& [name, value] : p.terms)
      if (name == "motion_smooth") smooth = value;
    joint.push_back(p.loss - c.w_motion_smooth * smooth);
  }
  BOOST_REQUIRE(joint.size() >= 4);
  const double fall = (joint[joint.size() - 1] + joint[joint.size() - 2]) / (joint[0] + joint[1]);
  BOOST_TEST_MESSAGE("tiny scene joint loss, last two records over first two: " << fall);
  BOOST_TEST(fall < 0.75);

  // Floor: the best constant image (the mean training colour) scores `baseline` on the
  // camera-0 views, a model that learnt nothing but the mean scores that, and untrained
  // networks score below it (measured 14.3 dB against a 16.0 dB baseline). In 400 steps
  // the paper's networks reach 17.00 dB and rigid objects on hash grids 17.92-18.00 under
  // the five BLAS kernels above; the floor is baseline + 0.5 (16.47). Rigid objects on the
  // paper's frequency encoding reach only 15.64-16.49 here (docs/known-issues.md), so the
  // paper's networks are checked with the (x, y, z, t) field they were made for.
  const Checkpoint ck = t.checkpoint();
  ViewRenderer r(runtime(), c, ray_geometry(scene), ck);
  double mean[3] = {0, 0, 0};
  size_t count = 0;
  for (const Frame& f : scene.frames)
    for (size_t i = 0; i < f.rgb.data.size(); i += 3, ++count)
      for (int k = 0; k < 3; ++k) mean[k] += f.rgb.data[i + k];
  double trained = 0, baseline = 0;
  int views = 0;
  for (const GroundTruthView& v : scene.gt_views) {
    if (v.kind != "cam0") continue;
    ViewRequest req;
    req.camera = v.camera;
    req.hard_blend = false;  // as `nova eval` renders the scene's own views
    req.instances = scene_instances(scene.num_objects, v.time);
    const ViewImage img = r.render(req);
    trained += psnr(float_rgb_to_image(img.rgb, img.width, img.height), v.rgb);
    Image8 flat(v.rgb.width, v.rgb.height, 3);
    for (size_t i = 0; i < flat.data.size(); ++i) flat.data[i] = static_cast<uint8_t>(std::lround(mean[i % 3] / count));
    baseline += psnr(flat, v.rgb);
    ++views;
  }
  BOOST_REQUIRE(views > 0);
  trained /= views;
  baseline /= views;
  BOOST_TEST_MESSAGE("tiny scene camera-0 PSNR " << trained << " dB, mean-colour baseline " << baseline << " dB");
  BOOST_TEST(trained > baseline + 0.5);
}

BOOST_AUTO_TEST_CASE(learns_the_tiny_scene) {
  // The paper's networks: frequency encoding, objects as fields of (x, y, z, t).
  TrainConfig c = tiny_config(Encoding::Frequency);
  set_config_value(c, "object-motion", "none");  // (and with it no object box)
  check_learns_the_tiny_scene(c);
}

BOOST_AUTO_TEST_CASE(learns_the_tiny_scene_with_rigid_objects) {
  // quick's object model: hash grids, a canonical shape per object moved by a learnt motion.
  TrainConfig c = tiny_config(Encoding::HashGrid);
  BOOST_REQUIRE(c.field.motion == ObjectMotion::Rigid);
  check_learns_the_tiny_scene(c);
}

BOOST_AUTO_TEST_CASE(learns_the_tiny_scene_with_samples_about_the_objects) {
  // A third of the samples crowded about the objects, in training (the device's warp) and in
  // the renders that score it (the host's, per instance). Measured 17.93 dB, a loss ratio of
  // 0.45, under OpenBLAS's default, Haswell and Zen kernels: the floors above hold.
  TrainConfig c = tiny_config(Encoding::HashGrid);
  c.object_samples = 8;
  BOOST_REQUIRE(uses_object_samples(c, ray_geometry(tiny_scene()), tiny_scene().num_objects));
  check_learns_the_tiny_scene(c);
}

BOOST_AUTO_TEST_CASE(samples_about_too_many_objects_are_refused_before_training) {
  // The device warp holds kMaxWarpObjects objects: a scene with more is an error that names
  // the option and the count, before the run folder is made.
  Scene scene = tiny_scene();
  const int K = static_cast<int>(kMaxWarpObjects) + 1;
  for (Frame& f : scene.frames)
    while (f.masks.size() < static_cast<size_t>(K) + 1) f.masks.push_back(f.masks.back());
  scene.num_objects = K;
  TrainConfig c = tiny_config(Encoding::HashGrid);
  c.object_samples = 8;
  TempDir dir("too_many");
  expect_error([&] { Trainer t(runtime(), scene, c, (dir / "run").string()); },
               {"object-samples", std::to_string(K)});
  BOOST_TEST(!std::filesystem::exists(dir / "run"));
}

BOOST_AUTO_TEST_CASE(resume_is_bit_identical) {
  const Scene scene = tiny_scene();
  // Stop at step 8 inside pretraining's hand-over (pretrain 5) and exactly at it (8): the
  // second half runs joint steps with augmentation (every 3rd from the first joint step).
  // With a rigid object motion too: its trajectory is a parameter like the others (set once
  // on entering the joint phase, then trained), and so are the objects' own boxes, into which
  // a step's samples may crowd (read from the motion on the device). `pretrain_only`: the
  // first half is a run of pretraining alone (no joint steps), which ends in pretraining at the
  // hand-over; resumed with joint steps it goes on as the straight run.
  struct Case {
    int pretrain;
    ObjectMotion motion;
    bool object_box;
    int object_samples;
    bool pretrain_only;
  };
  for (auto [pretrain, motion, object_box, object_samples, pretrain_only] :
       {Case{5, ObjectMotion::None, false, 0, false}, Case{8, ObjectMotion::None, false, 0, false},
        Case{5, ObjectMotion::Rigid, false, 0, false}, Case{5, ObjectMotion::Rigid, true, 0, false},
        Case{5, ObjectMotion::Rigid, true, 3, false}, Case{8, ObjectMotion::None, false, 0, true},
        Case{8, ObjectMotion::Rigid, true, 0, true}}) {
    TempDir dir("resume");
    TrainConfig c = tiny_config(Encoding::HashGrid);
    c.field.motion = motion;
    c.field.object_box = object_box;
    c.object_samples = object_samples;
    BOOST_REQUIRE(uses_object_samples(c, ray_geometry(scene), scene.num_objects) == (object_samples > 0));
    c.pretrain_steps = pretrain;
    c.steps = 11;
    c.rays = 64;
    c.samples = 8;
    // Occupancy updates on both sides of the split (phase steps 3, 5, 7, ...): the grids are
    // part of the state a resume restores.
    c.occupancy = true;
    c.occupancy_res = 16;
    c.occupancy_warmup = 3;
    c.occupancy_every = 2;
    const long n = 8, total = pretrain + c.steps;
    Trainer straight(runtime(), scene, c, (dir / "a").string());
    straight.run({}, total);
    {
      TrainConfig head = c;
      if (pretrain_only) head.steps = 0;
      Trainer first(runtime(), scene, head, (dir / "b").string());
      first.run({}, n);
      if (pretrain_only) BOOST_TEST(first.checkpoint().get("phase") == "pretrain");
    }
    Trainer second(runtime(), scene, c, (dir / "b").string());
    second.resume();
    BOOST_TEST(second.step() == n);
    second.run({}, total);
    const Checkpoint a = straight.checkpoint(), b = second.checkpoint();
    BOOST_TEST(a.get("rng") == b.get("rng"));
    BOOST_TEST(a.get("step") == b.get("step"));
    BOOST_TEST(a.get("adam_steps") == b.get("adam_steps"));
    BOOST_REQUIRE(a.arrays.size() == b.arrays.size());
    for (size_t i = 0; i < a.arrays.size(); ++i) {
      BOOST_TEST(a.arrays[i].name == b.arrays[i].name);
      BOOST_TEST(same_bits(a.arrays[i].values, b.arrays[i].values), "array " << a.arrays[i].name << ", pretrain " << pretrain);
    }
  }
}

// depth-start: pretraining's first steps train no depth term (metrics.jsonl records it as 0),
// the later ones do, and 0 keeps it from the first step.
BOOST_AUTO_TEST_CASE(depth_term_waits_for_depth_start) {
  const Scene scene = tiny_scene();
  BOOST_REQUIRE(disparity_usable(ray_geometry(scene)));
  for (int start : {0, 6}) {
    TempDir dir("depth_start");
    TrainConfig c = short_config(12, 0, 64, 8);
    c.log_every = 1;
    c.depth_start = start;
    Trainer t(runtime(), scene, c, (dir / "run").string());
    t.run({}, 12);
    const std::string metrics = read_all(dir / "run" / "metrics.jsonl");
    int records = 0;
    for (size_t at = metrics.find("\"step\":"); at != std::string::npos; at = metrics.find("\"step\":", at + 1)) {
      const long step = std::stol(metrics.substr(at + 7));
      const size_t d = metrics.find("\"depth\":", at);
      BOOST_REQUIRE(d != std::string::npos);
      const double depth = std::stod(metrics.substr(d + 8));
      BOOST_TEST((depth > 0.0) == (step > start), "step " << step << " depth " << depth << " start " << start);
      ++records;
    }
    BOOST_TEST(records == 12);
  }
}

// depth-ramp: the depth term's share of w-depth rises linearly from depth-start, and a share
// of 0 trains exactly as no depth term (the first pretraining step of a ramp is bit-identical
// to w-depth 0), while the ramp's later steps do not.
BOOST_AUTO_TEST_CASE(depth_ramp_scales_the_depth_term) {
  TrainConfig w;
  for (long s : {0L, 5L, 100L}) BOOST_TEST(w.depth_weight_at(s) == 1.0);
  w.depth_start = 2;
  w.depth_ramp = 4;
  const std::vector<double> expected{0, 0, 0, 0.25, 0.5, 0.75, 1, 1, 1};
  for (size_t s = 0; s < expected.size(); ++s) BOOST_TEST(w.depth_weight_at(static_cast<long>(s)) == expected[s]);
  w.depth_ramp = 0;
  BOOST_TEST(w.depth_weight_at(1) == 0.0);
  BOOST_TEST(w.depth_weight_at(2) == 1.0);

  const Scene scene = tiny_scene();
  BOOST_REQUIRE(disparity_usable(ray_geometry(scene)));
  const auto parameters = [&](float w_depth, int ramp, long steps) {
    TrainConfig c = short_config(12, 0, 64, 8);
    c.w_depth = w_depth;
    c.depth_ramp = ramp;
    return trained_for(scene, c, steps);
  };
  BOOST_TEST(same_parameters(parameters(0.5f, 10, 1), parameters(0.0f, 0, 1)));
  BOOST_TEST(!same_parameters(parameters(0.5f, 10, 3), parameters(0.0f, 0, 3)));
  BOOST_TEST(!same_parameters(parameters(0.5f, 10, 3), parameters(0.5f, 0, 3)));
}

// free-space-scene-fit: the surface of a pixel is the NDC t of its disparity placed by the fit.
// A camera at the origin looking down -z: the centre pixel's point lies at world z = -1 / w,
// so t = 1 - w exactly; a pixel off-centre at the same inverse depth lies at the same z (the
// depth is along the view axis). w <= 0 reads 1 (infinity), a point before the near plane 0.
// Trained, the option changes the joint steps (the free-space term reads another surface), and
// free-space-front changes them again.
BOOST_AUTO_TEST_CASE(free_space_surface_from_the_scene_fit) {
  Frame f;
  f.camera.width = 5, f.camera.height = 3;
  f.camera.fx = f.camera.fy = 4, f.camera.cx = 2, f.camera.cy = 1;
  f.disparity.width = 5, f.disparity.height = 3;
  f.disparity.data = {0.1f, 0.2f, 0.3f, 0.4f, 0.5f, -0.5f, 0.4f, 0.25f, 0.9f, 2.0f, 0.0f, 0.0f, 0.0f, 0.0f, 0.0f};
  DisparityFit fit;
  fit.ok = true, fit.scale = 2.0, fit.shift = -0.1;
  const std::vector<float> map = detail::surface_map(f, fit);
  BOOST_REQUIRE(map.size() == 15u);
  BOOST_TEST(map[7] == 1.0 - (2.0 * 0.25 - 0.1), boost::test_tools::tolerance(1e-6));  // centre
  BOOST_TEST(map[6] == 1.0 - (2.0 * 0.4 - 0.1), boost::test_tools::tolerance(1e-6));
  BOOST_TEST(map[5] == 1.0f);   // w = -1.1: at or beyond infinity
  BOOST_TEST(map[9] == 0.0f);   // w = 3.9: nearer than the near plane
  BOOST_TEST(map[1] == 1.0 - (2.0 * 0.2 - 0.1), boost::test_tools::tolerance(1e-6));
  PixelBatch b;
  b.pixels = {2, 1, 1, 1};
  const std::vector<float> t = detail::values_at_pixels(map, 5, b, 2);
  BOOST_TEST(t[0] == map[7]);
  BOOST_TEST(t[1] == map[6]);

  TrainConfig c = short_config(4, 3, 64, 8);
  c.w_free_space = 1.0f;
  c.free_space_scene_fit = c.free_space_front = false;
  const Checkpoint batch_fit = trained_for(tiny_scene(), c, 7);
  c.free_space_scene_fit = true;
  const Checkpoint scene_fit = trained_for(tiny_scene(), c, 7);
  BOOST_TEST(!same_parameters(batch_fit, scene_fit));
  c.free_space_front = true;
  BOOST_TEST(!same_parameters(scene_fit, trained_for(tiny_scene(), c, 7)));

  // Every frame from one camera: no parallax to place the disparity by (fit_disparity refuses),
  // so the run trains with the per-batch fit, bit for bit, and its config.ini says so.
  Scene still = tiny_scene();
  for (Frame& f : still.frames) f.camera = still.frames[0].camera;
  TempDir dir("no_parallax");
  Trainer fallback(runtime(), still, c, (dir / "run").string());
  fallback.run({}, 7);
  c.free_space_scene_fit = c.free_space_front = false;
  BOOST_TEST(same_parameters(fallback.checkpoint(), trained_for(still, c, 7)));
  const std::string ini = read_all(dir / "run" / "config.ini");
  BOOST_TEST(ini.find("free-space-scene-fit = false") != std::string::npos, ini);
}

// free-space-front: every pixel of an object's mask takes the tenth nearest (kFrontQuantile)
// of the mask's finite surfaces; 0 (before the near plane) and 1 (infinity) are not surfaces,
// a pixel of two masks takes the nearer front, pixels of no mask keep their own.
BOOST_AUTO_TEST_CASE(free_space_front_of_each_object) {
  std::vector<float> map(24);
  for (size_t i = 0; i < 12; ++i) map[i] = 0.30f + 0.01f * static_cast<float>(i);  // object 1: 0.30 .. 0.41
  map[0] = 0.0f;                                                                    // not a surface
  map[11] = 1.0f;                                                                   // nor infinity
  for (size_t i = 12; i < 24; ++i) map[i] = 0.60f + 0.01f * static_cast<float>(i - 12);
  std::vector<Image8> masks(3, Image8(6, 4, 1));
  for (size_t i = 0; i < 12; ++i) masks[1].data[i] = 255;
  for (size_t i = 12; i < 16; ++i) masks[2].data[i] = 255;  // object 2: 0.60 .. 0.63
  masks[2].data[10] = 200;                                  // also object 2's: the nearer front wins
  std::vector<float> fronts = map;
  detail::to_object_fronts(fronts, masks);
  // Object 1's finite surfaces 0.31 .. 0.40 (ten): the tenth nearest is index 0.1 * 9 -> 0: 0.31.
  for (size_t i = 0; i < 12; ++i) BOOST_TEST(fronts[i] == map[1], "pixel " << i);
  // Object 2's 0.60 .. 0.63 and pixel 10's 0.40 (five): index 0.1 * 4 -> 0: 0.40, the nearest
  // of five. Pixel 10 keeps object 1's nearer 0.31.
  for (size_t i = 12; i < 16; ++i) BOOST_TEST(fronts[i] == map[10], "pixel " << i);
  for (size_t i = 16; i < 24; ++i) BOOST_TEST(fronts[i] == map[i], "pixel " << i);
  // A mask with no finite surface leaves its pixels as they were.
  std::vector<float> empty(24, 1.0f);
  detail::to_object_fronts(empty, masks);
  BOOST_TEST((empty == std::vector<float>(24, 1.0f)));

  TrainConfig c = preset_config("quick");
  c.free_space_front = true;
  c.free_space_scene_fit = false;
  try {
    validate(c);
    BOOST_FAIL("free-space-front without free-space-scene-fit was accepted");
  } catch (const Error& e) {
    const std::string what = e.what();
    BOOST_TEST(what.find("free-space-front") != std::string::npos, what);
    BOOST_TEST(what.find("free-space-scene-fit") != std::string::npos, what);
  }
}

// A rigid object starts where its masks are: on entering the joint phase every frame's
// anchor (the motion's translation) projects into that frame inside the object's mask, and
// in front of the camera; its first frame is unturned (it fixes the canonical space), and
// the turn the frames' alignment finds by the last frame is the world's (2.7 and 2.25 rad on
// this 64 x 48 scene; measured 14 % and 2 % off, bound 30 %: about twice the worst).
BOOST_AUTO_TEST_CASE(rigid_objects_start_at_their_masks) {
  const Scene scene = tiny_scene();
  TempDir dir("rigid");
  TrainConfig c = tiny_config(Encoding::HashGrid);
  c.field.motion = ObjectMotion::Rigid;
  c.field.object_box = true;
  c.pretrain_steps = 60;
  c.steps = 1;
  c.lr = 0.0f;  // the one joint step leaves the motion where it started
  Trainer t(runtime(), scene, c, (dir / "run").string());
  t.run({}, c.pretrain_steps + 1);
  const Checkpoint ck = t.checkpoint();
  const CheckpointArray& m = ck.array("objects.motion");
  const int K = scene.num_objects, F = static_cast<int>(scene.frames.size());
  BOOST_REQUIRE(m.values.size() == static_cast<size_t>(K * F * 6));
  for (int k = 1; k <= K; ++k) {
    const float* rows = m.values.data() + static_cast<size_t>(k - 1) * F * 6;
    for (int f = 0; f < F; ++f) {
      const Frame& fr = scene.frames[static_cast<size_t>(f)];
      const Camera& cam = fr.camera;
      double local[3];  // camera axes (right, up, back) of the anchor
      for (int a = 0; a < 3; ++a) {
        local[a] = 0;
        for (int r = 0; r < 3; ++r) local[a] += cam.rotation(r, a) * (rows[f * 6 + 3 + r] - cam.position(r));
      }
      BOOST_TEST(local[2] < 0.0, "object " << k << " frame " << f << " anchor behind the camera");
      const int x = static_cast<int>(std::lround(cam.cx + cam.fx * local[0] / -local[2]));
      const int y = static_cast<int>(std::lround(cam.cy - cam.fy * local[1] / -local[2]));
      const Image8& mask = fr.masks[static_cast<size_t>(k)];
      const bool inside = x >= 0 && y >= 0 && x < mask.width && y < mask.height && mask.at(x, y) >= 128;
      BOOST_TEST(inside, "object " << k << " frame " << f << ": anchor at pixel (" << x << ", " << y << ")");
      if (f == 0)
        for (int a = 0; a < 3; ++a) BOOST_TEST(rows[a] == 0.0f);
    }
    const float* last = rows + static_cast<size_t>(F - 1) * 6;
    const Mat3 turn = euler_xyz_to_matrix({last[0], last[1], last[2]});
    const double found = std::acos(std::clamp((turn[0] + turn[4] + turn[8] - 1) / 2, -1.0, 1.0));
    const SynthWorld world("tiny", 7);
    const double spin = std::fabs(world.scene().objects[static_cast<size_t>(k - 1)].motion.spin_rate) * (F - 1) / F;
    BOOST_TEST_MESSAGE("object " << k << ": turn " << found << " rad by the last frame, the world's " << spin);
    BOOST_TEST(std::fabs(found - spin) < 0.3 * spin);
    // Its box (object-box) sits at the pivot, in NDC, and is at most the scene's box: this
    // 64 x 48 scene's objects fill much of the frame, so only a lower bound is tight.
    const CheckpointArray& box = ck.array(kObjectBoxName);
    BOOST_REQUIRE(box.values.size() == static_cast<size_t>(K * 6));
    const float* b = box.values.data() + static_cast<size_t>(k - 1) * 6;
    const RayGeometry geo = ray_geometry(scene);
    const Vec3 q = motion_pivot(rows, F);
    const Vec3 centre{geo.ax * q[0] / q[2], geo.ay * q[1] / q[2], 1 + 2 / q[2]};
    for (size_t j = 0; j < 3; ++j) {
      BOOST_TEST(std::fabs(b[j] - centre[j]) < 1e-5, "object " << k << " box centre axis " << j);
      const double half = std::exp(-double(b[3 + j]));
      BOOST_TEST_MESSAGE("object " << k << " box half-size axis " << j << ": " << half);
      BOOST_TEST((half > 0.01 && half <= geo.box[j] * (1 + 1e-6)), "object " << k << " box half-size axis " << j << ": " << half);
    }
  }
}

// object-box-bounded: once the joint phase starts, each object's occupancy grid holds no
// occupied cell outside its box (the fraction a grid bounded by the checkpoint's box has,
// below 1 on this scene), and a resumed run bounds its grids the same way.
BOOST_AUTO_TEST_CASE(bounded_object_boxes_bound_the_occupancy_grids) {
  const Scene scene = tiny_scene();
  TempDir dir("bounded");
  TrainConfig c = tiny_config(Encoding::HashGrid);
  c.field.motion = ObjectMotion::Rigid;
  c.field.object_box = true;
  c.field.object_box_bounded = true;
  c.occupancy = true;
  c.pretrain_steps = 20;
  c.steps = 4;
  c.log_every = 1;
  c.checkpoint_every = 2;
  std::vector<TrainProgress> log;
  {
    Trainer t(runtime(), scene, c, (dir / "run").string());
    t.run([&](const TrainProgress& p) { log.push_back(p); }, c.pretrain_steps + 2);
  }
  Trainer resumed(runtime(), scene, c, (dir / "run").string());
  resumed.resume();
  resumed.run([&](const TrainProgress& p) { log.push_back(p); });
  const Checkpoint ck = resumed.checkpoint();
  const std::vector<float>& boxes = ck.array(kObjectBoxName).values;
  const int K = scene.num_objects;
  BOOST_REQUIRE(boxes.size() == static_cast<size_t>(K * 6));
  const float bound = scene_field(c.field, ray_geometry(scene)).occupancy_bound;
  size_t joint = 0;
  for (const TrainProgress& p : log) {
    if (p.phase != "joint") continue;
    ++joint;
    BOOST_REQUIRE(p.occupied.size() == static_cast<size_t>(K + 1));
    for (int k = 1; k <= K; ++k) {
      OccupancyGrid g(c.occupancy_res, bound, c.occupancy_alpha);
      const float* b = boxes.data() + (k - 1) * 6;
      std::vector<float> support(6);
      for (size_t d = 0; d < 3; ++d) {
        support[d] = b[d] - std::exp(-b[3 + d]);
        support[3 + d] = b[d] + std::exp(-b[3 + d]);
      }
      g.set_support(support);
      // Before the grids' warm-up every cell in the box counts as occupied.
      BOOST_TEST(g.occupied_fraction() < 1.0, "object " << k);
      BOOST_TEST(p.occupied[static_cast<size_t>(k)] == g.occupied_fraction(), "object " << k << " at step " << p.step);
    }
  }
  BOOST_TEST(joint == 4u);  // two joint steps before the resume, two after
  // Without a box of its own the canonical field spans the scene's box: nothing is bounded.
  {
    TrainConfig sc = c;
    sc.field.object_box = false;
    sc.steps = 1;
    std::vector<TrainProgress> plain;
    Trainer t(runtime(), scene, sc, (dir / "scene_box").string());
    t.run([&](const TrainProgress& p) { plain.push_back(p); });
    BOOST_REQUIRE(plain.back().phase == "joint");
    for (int k = 1; k <= K; ++k) BOOST_TEST(plain.back().occupied.at(static_cast<size_t>(k)) == 1.0);
  }
  // A renderer of the run bounds the saved grids too: it runs fewer object samples than one
  // that reads the same checkpoint unbounded.
  size_t evaluated[2] = {0, 0};
  for (bool bounded : {false, true}) {
    TrainConfig rc = c;
    rc.field.object_box_bounded = bounded;
    ViewRenderer r(runtime(), rc, ray_geometry(scene), ck);
    ViewRequest req;
    req.camera = scene.frames[0].camera;
    req.instances = scene_instances(K, scene.frames[0].time);
    r.render(req);
    evaluated[bounded] = r.last_stats().evaluated;
  }
  BOOST_TEST_MESSAGE("field evaluations of frame 0: " << evaluated[0] << " unbounded, " << evaluated[1] << " bounded");
  BOOST_TEST(evaluated[1] < evaluated[0]);
}

// The reference code's conventions end to end (plain pretraining, then joint steps with the
// per-NeRF own targets on augmented steps, the L1 mask, area RGB, outside alpha and order
// terms): every logged loss is finite, the order term is there, and the run resumes
// bit-identically across the phase change.
BOOST_AUTO_TEST_CASE(reference_conventions_train_and_resume) {
  const Scene scene = tiny_scene();
  TempDir dir("refconv");
  TrainConfig c = tiny_config(Encoding::HashGrid);
  c.conventions = reference_conventions();
  c.weights.order = 0.1f;
  c.pretrain_steps = 5;
  c.steps = 9;
  c.rays = 64;
  c.samples = 8;
  c.log_every = 1;
  std::vector<TrainProgress> log;
  Trainer straight(runtime(), scene, c, (dir / "a").string());
  straight.run([&](const TrainProgress& p) { log.push_back(p); });
  bool order = false, augmented = false;
  for (const TrainProgress& p : log) {
    BOOST_TEST(std::isfinite(p.loss), "step " << p.step);
    for (const auto& [name, v] : p.terms) {
      BOOST_TEST(std::isfinite(v), name << " at step " << p.step);
      order = order || name == "order";
    }
    augmented = augmented || p.augmented;
  }
  BOOST_TEST(order);
  BOOST_TEST(augmented);
  {
    Trainer first(runtime(), scene, c, (dir / "b").string());
    first.run({}, 7);
  }
  Trainer second(runtime(), scene, c, (dir / "b").string());
  second.resume();
  second.run({});
  const Checkpoint a = straight.checkpoint(), b = second.checkpoint();
  BOOST_REQUIRE(a.arrays.size() == b.arrays.size());
  for (size_t i = 0; i < a.arrays.size(); ++i)
    BOOST_TEST(same_bits(a.arrays[i].values, b.arrays[i].values), "array " << a.arrays[i].name);
}

// The hot path of a training step makes no blocking read of a per-sample buffer: packing,
// jitter, density noise and the objects' times all stay on the device. Measured per step
// through the runtime's transfer counters (the progress callback runs after every step with
// log_every 1 and resets them). Allowed per step: reads of at most 4 values (each pack op's
// per-batch counts, at most 2 here, and the logged scalars), writes of per-ray data only (the
// largest, target colours per NeRF, N R 3 floats) and never R S floats. The steps of an
// occupancy update (which probes the grids' cells: every 16 steps, not the hot path) and the
// step after it (whose pack copies the new grids to the device) are left out.
BOOST_AUTO_TEST_CASE(step_hot_path_reads_no_per_sample_buffer) {
  const Scene scene = tiny_scene();
  TempDir dir("transfers");
  TrainConfig c = tiny_config(Encoding::HashGrid);
  c.pretrain_steps = 20;
  c.steps = 40;
  c.occupancy = true;
  c.occupancy_res = 32;
  c.occupancy_warmup = 4;
  c.occupancy_every = 16;
  c.log_every = 1;
  Trainer t(runtime(), scene, c, (dir / "run").string());
  const size_t R = static_cast<size_t>(c.rays), S = static_cast<size_t>(c.samples);
  const size_t N = 1 + static_cast<size_t>(scene.num_objects);
  size_t checked = 0, packed_steps = 0;
  runtime().reset_transfers();
  t.run([&](const TrainProgress& p) {
    const TransferStats x = runtime().transfers();
    runtime().reset_transfers();
    // Steps are counted from 1 here; phase step k + 1 updates the grids after step k.
    const long phase_step = p.step <= c.pretrain_steps ? p.step : p.step - c.pretrain_steps;
    const long since = phase_step - c.occupancy_warmup;
    const bool near_update = since >= 0 && (since % c.occupancy_every <= 1);
    const bool first_of_phase = p.step == 1 || p.step == c.pretrain_steps + 1;
    if (near_update || first_of_phase) return;
    ++checked;
    packed_steps += p.kept < 1.0;
    BOOST_TEST(x.largest_read <= 4 * sizeof(float), "step " << p.step << " read " << x.largest_read << " bytes");
    BOOST_TEST(x.largest_write <= N * R * 3 * sizeof(float), "step " << p.step << " wrote " << x.largest_write << " bytes");
    BOOST_TEST(x.largest_write < R * S * sizeof(float));
  });
  BOOST_TEST(checked >= 40u);
  BOOST_TEST(packed_steps > 0u);  // the grids skipped samples in some checked steps
}

// A short run with occupancy grids (alpha 0.1 over one cell, so that it skips two thirds of
// its samples), trained once for the skipping and the termination cases.
struct GridRun {
  Scene scene;
  TrainConfig config;
  Checkpoint checkpoint;
  double kept = 1;  // samples kept in the last logged step
};
const GridRun& grid_run() {
  static const GridRun run = [] {
    GridRun g;
    g.scene = tiny_scene();
    TempDir dir("skip");
    TrainConfig& c = g.config;
    c = tiny_config(Encoding::HashGrid);
    c.pretrain_steps = 100;
    c.steps = 150;
    c.occupancy = true;
    c.occupancy_res = 32;
    c.occupancy_warmup = 50;
    c.occupancy_every = 16;
    c.occupancy_alpha = 0.1f;
    // These cases measure skipping and termination against the unskipped render of one model;
    // quick's two object priors make this 250-step model one where they cost more (skipped
    // against full: 25.8 dB; the static NeRF behind the objects keeps the haze of its
    // initialisation, which objects still half transparent let through and the grids drop),
    // so the model is trained without them (docs/known-issues.md).
    c.static_background_only = false;
    c.w_free_space = 0.0f;
    // The depth term at full weight from the first step: with quick's ramp (250 steps, beyond
    // this model's 100 of pretraining) the static NeRF is another model, on which the floors
    // below were not set (skipped against full 25.5 dB, the objects' grids not empty).
    c.depth_ramp = 0;
    // With the box that holds every training ray (hash-ndc-box-from-rays) this 250-step model
    // also keeps haze in the box's outer cells, which the grids drop (skipped against full
    // 23.5 dB): the cases below are defined on the [-1, 1] box's model, quick's default.
    BOOST_REQUIRE(!c.field.ndc_box_from_rays);
    // The paper's (x, y, z, t) field: its objects stay a faint haze in 150 joint steps, so
    // that their grids mark no cell occupied (default_pivot_falls_back_to_the_origin).
    set_config_value(c, "object-motion", "none");
    Trainer t(runtime(), g.scene, c, (dir / "run").string());
    t.run([&](const TrainProgress& p) { g.kept = p.kept; });
    g.checkpoint = t.checkpoint();
    return g;
  }();
  return run;
}

double max_abs_diff(const std::vector<float>& a, const std::vector<float>& b) {
  double m = 0;
  for (size_t i = 0; i < a.size(); ++i) m = std::max(m, std::fabs(static_cast<double>(a[i]) - b[i]));
  return m;
}

// Empty-space skipping changes what a trained model renders by little: the same checkpoint
// rendered with its occupancy grids and with every sample. A skipped sample lies in a cell
// whose probed density stayed under the threshold, and dropping it also drops its blend
// share, which shifts colour between NeRFs where an occupied one shares the sample.
// Measured: 33% of the samples kept, worst camera-0 view 34.8 dB between the two renders;
// the floor is 30 dB (3% RMS), below which skipping would visibly change the picture.
BOOST_AUTO_TEST_CASE(skipping_empty_space_keeps_the_render) {
  const GridRun& g = grid_run();
  const Scene& scene = g.scene;
  BOOST_TEST_MESSAGE("samples kept in the last logged step: " << g.kept);
  BOOST_TEST(g.kept < 0.9);  // the grids must skip something for this test to mean anything
  ViewRenderer r(runtime(), g.config, ray_geometry(scene), g.checkpoint);
  BOOST_REQUIRE(r.skips_empty_space());
  r.set_early_termination(false);  // this case measures skipping alone
  double worst = 1e9;
  for (const ViewRequest& req : cam0_requests(scene)) {
    r.set_skip_empty_space(true);
    const ViewImage skipped = r.render(req);
    r.set_skip_empty_space(false);
    const ViewImage full = r.render(req);
    const double p = psnr(float_rgb_to_image(skipped.rgb, skipped.width, skipped.height),
                          float_rgb_to_image(full.rgb, full.width, full.height));
    worst = std::min(worst, p);
  }
  BOOST_TEST_MESSAGE("skipped against full render: worst PSNR " << worst << " dB");
  BOOST_TEST(worst > 30.0);
}

// Early ray termination against the same render without it (both skipping empty space). A
// ray stops when its transmittance T_s after the checked sample is under 1e-4; what it
// loses is T_s C_2 with every channel of C_2 (colour, acc, each mask) at most acc_2 <= 1,
// so at most 1e-4 (depth: 1e-4 times the far depth). Rays that go on differ by float
// rounding alone: T_s is read as 1 - acc_1 and the second segment restarts its product,
// each off by at most ~S 2^-24 = 1.4e-6 relative (S = 24); the tolerance adds 1e-5 for it.
// Rays never stopped must match to that 1e-5 (checked on the render with termination on and
// a floor of 0, which splits every ray and stops none). Measured: 19290 of 30720 rays stop
// at S/2; max |diff| rgb 5.4e-5, acc and masks 9.9e-5, depth 5.5e-5; split alone 3.0e-7;
// the floor-0.5 mutation 1.7e-2.
BOOST_AUTO_TEST_CASE(early_termination_keeps_the_render) {
  const GridRun& g = grid_run();
  const Scene& scene = g.scene;
  const RayGeometry geo = ray_geometry(scene);
  ViewRenderer r(runtime(), g.config, geo, g.checkpoint);
  BOOST_REQUIRE(r.early_termination().on);  // on by default
  const double tol = 1e-4 + 1e-5, noise = 1e-5, depth_scale = std::max(1.0f, geo.far);
  size_t rays = 0, terminated = 0;
  double worst_rgb = 0, worst_other = 0, worst_depth = 0, worst_split = 0, worst_early = 0;
  for (const ViewRequest& req : cam0_requests(scene)) {
    r.set_early_termination(false);
    const ViewImage full = r.render(req);
    r.set_early_termination(EarlyTermination{});
    const ViewImage term = r.render(req);
    // A view in one chunk is its own probe: it always runs in passes.
    BOOST_TEST(std::count(r.last_stats().split.begin(), r.last_stats().split.end(), 0) == 0);
    rays += r.last_stats().rays;
    terminated += r.last_stats().terminated;
    worst_rgb = std::max(worst_rgb, max_abs_diff(term.rgb, full.rgb));
    worst_other = std::max(worst_other, max_abs_diff(term.acc, full.acc));
    for (size_t m = 0; m < full.masks.size(); ++m)
      worst_other = std::max(worst_other, max_abs_diff(term.masks[m], full.masks[m]));
    worst_depth = std::max(worst_depth, max_abs_diff(term.depth, full.depth) / depth_scale);
    // Split, nothing stopped: the combination itself, to float rounding.
    r.set_early_termination(EarlyTermination{true, 0.0f, {}, 0.0f});
    const ViewImage split = r.render(req);
    BOOST_TEST(r.last_stats().terminated == 0u);
    worst_split = std::max({worst_split, max_abs_diff(split.rgb, full.rgb), max_abs_diff(split.acc, full.acc)});
    // The mutation: rays stopped at a floor of 0.5 lose up to half their colour, which the
    // comparison above must see (or it would pass whatever termination did).
    r.set_early_termination(EarlyTermination{true, 0.5f, {}});
    worst_early = std::max(worst_early, max_abs_diff(r.render(req).acc, full.acc));
  }
  BOOST_TEST_MESSAGE("early termination: " << terminated << " of " << rays << " rays stopped; max |diff| rgb "
                     << worst_rgb << ", acc and masks " << worst_other << ", depth / far " << worst_depth
                     << "; split without stopping " << worst_split << "; floor 0.5 " << worst_early);
  BOOST_TEST(terminated > 0u);  // some ray must stop for this case to test anything
  BOOST_TEST(worst_rgb <= tol);
  BOOST_TEST(worst_other <= tol);
  BOOST_TEST(worst_depth <= tol);
  BOOST_TEST(worst_split <= noise);
  BOOST_TEST(worst_early > tol);
}

// The adaptive switch (EarlyTermination::pays_from) on views cut into chunks of 512 rays.
// Where rays stop (the default floor) most probes pay, so more chunks run in passes than the
// probes alone, within the bound above. Where none can stop (a floor of 0: the hazy extreme)
// the first chunk probes, the next `probe_every` run in one pass and equal the unterminated
// render bit for bit (the same graph over the same samples), then another probe; probes
// differ by the split's float rounding (1e-5, as above). Termination off never splits. Measured:
// all 60 chunks in passes where rays stop (each stops >= 15% of its rays; 20 would be probes
// alone), max |diff| 9.9e-5; probes 2.4e-7 where none can stop.
BOOST_AUTO_TEST_CASE(early_termination_runs_one_pass_where_it_does_not_pay) {
  const GridRun& g = grid_run();
  const Scene& scene = g.scene;
  const size_t R = 512;
  ViewRenderer r(runtime(), g.config, ray_geometry(scene), g.checkpoint, static_cast<int>(R));
  const EarlyTermination defaults;
  BOOST_REQUIRE(defaults.pays_from > 0.0f);
  const size_t every = static_cast<size_t>(defaults.probe_every);
  const double tol = 1e-4 + 1e-5, noise = 1e-5;
  size_t chunks = 0, probes = 0, paying_split = 0, terminated = 0;
  double worst_paying = 0, worst_probe = 0;
  bool one_pass_exact = true;
  for (const ViewRequest& req : cam0_requests(scene)) {
    r.set_early_termination(false);
    const ViewImage full = r.render(req);
    const std::vector<uint8_t> off = r.last_stats().split;
    BOOST_TEST(std::count(off.begin(), off.end(), 1) == 0);
    BOOST_TEST(r.last_stats().passes == off.size());
    BOOST_REQUIRE(off.size() >= every + 2);  // a probe, one-pass chunks, another probe
    chunks += off.size();
    probes += (off.size() + every) / (every + 1);

    r.set_early_termination(defaults);
    const ViewImage paying = r.render(req);
    const std::vector<uint8_t>& split = r.last_stats().split;
    paying_split += static_cast<size_t>(std::count(split.begin(), split.end(), 1));
    terminated += r.last_stats().terminated;
    worst_paying = std::max({worst_paying, max_abs_diff(paying.rgb, full.rgb), max_abs_diff(paying.acc, full.acc)});

    EarlyTermination hazy;
    hazy.below = 0.0f;
    r.set_early_termination(hazy);
    const ViewImage one = r.render(req);
    const std::vector<uint8_t> sched = r.last_stats().split;
    BOOST_REQUIRE(sched.size() == off.size());
    const size_t P = static_cast<size_t>(one.width) * one.height;
    for (size_t c = 0; c < sched.size(); ++c) {
      const bool probe = c % (every + 1) == 0;
      BOOST_TEST(sched[c] == probe, "chunk " << c);
      for (size_t p = c * R; p < std::min(P, (c + 1) * R); ++p) {
        const double d = std::max(std::fabs(static_cast<double>(one.acc[p]) - full.acc[p]),
                                  std::fabs(static_cast<double>(one.rgb[p * 3]) - full.rgb[p * 3]));
        if (probe) worst_probe = std::max(worst_probe, d);
        if (!probe && !(one.rgb[p * 3] == full.rgb[p * 3] && one.rgb[p * 3 + 1] == full.rgb[p * 3 + 1] &&
                        one.rgb[p * 3 + 2] == full.rgb[p * 3 + 2] && one.acc[p] == full.acc[p] &&
                        one.depth[p] == full.depth[p]))
          one_pass_exact = false;
      }
    }
    BOOST_TEST(r.last_stats().terminated == 0u);
  }
  BOOST_TEST_MESSAGE("adaptive termination, " << chunks << " chunks of " << R << " rays: " << paying_split
                     << " in passes where rays stop (" << terminated << " rays stopped, max |diff| " << worst_paying
                     << "), " << probes << " probes where none can; probe chunks max |diff| " << worst_probe);
  BOOST_TEST(terminated > 0u);
  BOOST_TEST(paying_split > probes);  // the switch kept passes where they pay
  BOOST_TEST(worst_paying <= tol);
  BOOST_TEST(one_pass_exact);
  BOOST_TEST(worst_probe <= noise);
}

// An instance without pivot= turns about its object's centre, found from the trained
// density (ViewRenderer::object_centre; tests/test_object_centre.cpp checks it on a field of
// known density). On the skipping run the objects stay faint: their grids mark no cell
// occupied, so a render that skips empty space draws nothing of them, has no centre for
// them, and falls back to the scene origin (render and eval warn); the same from a second
// renderer. With skipping off every cell is probed and the faint haze has a centre.
BOOST_AUTO_TEST_CASE(default_pivot_falls_back_to_the_origin) {
  const GridRun& g = grid_run();
  const Scene& scene = g.scene;
  const RayGeometry geo = ray_geometry(scene);
  // Objects with density everywhere (each object field's density output raised by 5) beside
  // occupancy grids that mark none of their cells: what the renderer does then should not rest
  // on how faint a haze 150 joint steps happen to leave.
  Checkpoint ck = g.checkpoint;
  bool raised = false;
  for (CheckpointArray& a : ck.arrays) {
    if (a.name != "objects.trunk.out.b") continue;
    BOOST_REQUIRE(a.values.size() == 5u * static_cast<size_t>(scene.num_objects));  // [rgb, sigma, blend]
    for (size_t i = 3; i < a.values.size(); i += 5) a.values[i] += 5.0f;
    raised = true;
  }
  BOOST_REQUIRE(raised);
  ViewRenderer r(runtime(), g.config, geo, ck), again(runtime(), g.config, geo, ck);
  BOOST_REQUIRE(r.skips_empty_space());
  for (int k = 1; k <= scene.num_objects; ++k) {
    BOOST_TEST_CONTEXT("object " << k) {
      const CheckpointArray& a = ck.array(occupancy_array_name(k));
      OccupancyGrid grid(static_cast<int>(a.shape[0]), scene_field(g.config.field, geo).occupancy_bound,
                         g.config.occupancy_alpha);
      grid.density = a.values;
      grid.refresh();
      BOOST_REQUIRE(grid.occupied_fraction() == 0.0);
      ComposeInstance inst;
      inst.object = k;
      inst.time = scene.frames.back().time;
      inst.rotate_deg = {0, 30, 0};
      const InstancePivot pv = r.pivot_for(inst);
      BOOST_TEST(!r.object_centre(k, inst.time).found);
      BOOST_TEST((pv.from == InstancePivot::From::Origin));
      BOOST_TEST((pv.pivot == std::array<double, 3>{0, 0, 0}));
      // An explicit pivot is kept as given.
      inst.pivot = std::array<double, 3>{0.25, -0.5, -2};
      const InstancePivot given = r.pivot_for(inst);
      BOOST_TEST((given.from == InstancePivot::From::Spec));
      BOOST_TEST((given.pivot == *inst.pivot));
      inst.pivot.reset();
      again.set_skip_empty_space(false);
      const InstancePivot all = again.pivot_for(inst);
      BOOST_TEST((all.from == InstancePivot::From::Density));
    }
  }
}

BOOST_AUTO_TEST_CASE(mismatched_checkpoints_are_refused) {
  const Scene scene = tiny_scene();
  TempDir dir("mismatch");
  TrainConfig c = short_config(2, 2, 32, 4);
  {
    Trainer t(runtime(), scene, c, (dir / "run").string());
    t.run();
  }
  TrainConfig wider = c;
  wider.field.width = c.field.width + 16;
  Trainer other(runtime(), scene, wider, (dir / "run").string());
  BOOST_CHECK_EXCEPTION(other.resume(), Error, [](const Error& e) {
    return std::string(e.what()).find("networks") != std::string::npos && e.exit_code() == kExitUsage;
  });
  // The same trunk with the other encoding, or a hash grid with other tables.
  TrainConfig frequency = c;
  frequency.field.encoding = Encoding::Frequency;
  TrainConfig bigger_tables = c;
  bigger_tables.field.hash.log2_size += 1;
  for (const TrainConfig& o : {frequency, bigger_tables}) {
    Trainer t(runtime(), scene, o, (dir / "run").string());
    BOOST_CHECK_EXCEPTION(t.resume(), Error, [](const Error& e) {
      return std::string(e.what()).find("networks") != std::string::npos;
    });
  }
  // A damaged file: one flipped byte in the middle.
  const fs::path ck = dir / "run" / kCheckpointFile;
  std::string bytes = read_all(ck);
  bytes[bytes.size() / 2] ^= 0x5a;
  write_all(ck, bytes);
  Trainer third(runtime(), scene, c, (dir / "run").string());
  BOOST_CHECK_EXCEPTION(third.resume(), Error, [](const Error& e) {
    return std::string(e.what()).find("corrupt") != std::string::npos;
  });
}

// align-depth-auto: the trainer reads the scene's disparity once; the tiny scene's exact
// disparity leaves the start's depth as given, the same disparity box-blurred over 5 pixels
// takes the nearest depth within a pixel, and the run's config.ini holds the choice.
BOOST_AUTO_TEST_CASE(align_depth_auto_reads_the_disparity_at_the_silhouettes) {
  TrainConfig c = short_config(0, 1, 64, 8);
  c.field.motion = ObjectMotion::Rigid;
  c.align_depth_auto = true;
  const auto chosen = [&](const Scene& scene) {
    TempDir dir("depth_auto");
    Trainer t(runtime(), scene, c, (dir / "run").string());
    t.run({}, 0);
    const std::string ini = read_all(dir / "run" / "config.ini");
    return ini.find("align-depth-reach = 1") != std::string::npos ? 1
           : ini.find("align-depth-reach = 0") != std::string::npos ? 0 : -1;
  };
  const Scene sharp = tiny_scene();
  const std::optional<double> share = silhouette_step_share(sharp);
  BOOST_REQUIRE(share.has_value());
  BOOST_TEST(*share > kBlurredStepShare);
  BOOST_TEST(chosen(sharp) == 0);
  Scene blurred = sharp;
  for (Frame& f : blurred.frames) box_blur(f.disparity, 2);
  const std::optional<double> blurred_share = silhouette_step_share(blurred);
  BOOST_REQUIRE(blurred_share.has_value());
  BOOST_TEST(*blurred_share < kBlurredStepShare);
  BOOST_TEST(chosen(blurred) == 1);
  c.align_depth_reach = 2.0f;  // a reach given is kept
  TempDir dir("depth_given");
  Trainer t(runtime(), blurred, c, (dir / "run").string());
  t.run({}, 0);
  BOOST_TEST(read_all(dir / "run" / "config.ini").find("align-depth-reach = 2") != std::string::npos);
}

BOOST_AUTO_TEST_SUITE_END()

}  // namespace nova::test

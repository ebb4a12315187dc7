// `nova train`, `nova render` and `nova eval` as a user runs them on the tiny synthetic
// scene: the files each promises, and exit code 2 with a message naming the problem (and
// nothing left behind) for every bad input.
#include <boost/test/unit_test.hpp>
#include <cstdlib>
#include <sys/wait.h>

#include "nova/io/image_io.hpp"
#include "nova/io/video.hpp"
#include "scene_test_util.hpp"

namespace nova::test {
namespace {

using Result = CommandResult;

Result nova_cli(const std::string& args, const TempDir& dir) { return run_built("nova", args, dir); }

// The smallest networks (small hash tables: quick's 2^16 x 16 levels would make every
// checkpoint 75 MB) and schedule that exercise every phase (pretraining, joint, augmented
// steps) in a few seconds.
const std::string kTiny =
    " --hash-levels 4 --hash-log2-size 10 --hash-max-res 32"
    " --depth 2 --width 16 --skip -1 --pos-freqs 4 --dir-freqs 2 --rays 64 --samples 8"
    " --pretrain-steps 3 --steps 6 --augment-start 0 --log-every 3 --checkpoint-every 4";

bool has_cli() { return fs::exists(fs::path(NOVA_BINARY_DIR) / "nova"); }

}  // namespace

BOOST_AUTO_TEST_SUITE(cli_run)

BOOST_AUTO_TEST_CASE(train_render_compose_eval_write_their_files) {
  if (!has_cli()) return;
  TempDir dir("cli-run");
  const std::string scene = cached_tiny_scene().string(), run = (dir / "run").string();
  Result t = nova_cli("train --scene " + scene + " --out " + run + kTiny, dir);
  BOOST_REQUIRE_MESSAGE(t.code == 0, t.err);
  for (const char* f : {"config.ini", "metrics.jsonl", "checkpoint.bin"}) BOOST_TEST(fs::exists(dir / "run" / f), f);
  BOOST_TEST(t.err.find("eta") != std::string::npos);  // the progress line
  const std::string metrics = read_all(dir / "run" / "metrics.jsonl");
  for (const char* key : {"\"step\":9", "\"psnr\":", "\"rays_per_s\":", "\"alpha\":", "\"blending\":"})
    BOOST_TEST(metrics.find(key) != std::string::npos, key);

  // Every frame time from camera 0: colour, depth and one mask per NeRF, and the video (a
  // build without OpenCV's videoio refuses --video before it renders anything).
  if (!video_supported()) {
    Result v = nova_cli("render --run " + run + " --out " + (dir / "frames").string() + " --video", dir);
    BOOST_TEST(v.code == 2);
    BOOST_TEST(v.err.find("--video") != std::string::npos, v.err);
    BOOST_TEST(!fs::exists(dir / "frames"));
    BOOST_TEST(!fs::exists(dir / "frames.partial"));
  }
  const std::string video = video_supported() ? " --video" : "";
  Result r = nova_cli("render --run " + run + " --out " + (dir / "frames").string() + video, dir);
  BOOST_REQUIRE_MESSAGE(r.code == 0, r.err);
  for (const char* f : {"000.png", "009.png", "000_depth.png", "000_mask0.png", "000_mask2.png"})
    BOOST_TEST(fs::exists(dir / "frames" / f), f);
  BOOST_TEST(fs::exists(dir / "frames" / "video.mp4") == video_supported());
  BOOST_TEST(!fs::exists(dir / "frames.partial"));

  // A composition of three instances (one object twice), from a spec the user wrote, and an
  // object turned edge-on (in NDC its far samples go to infinity and must pack all the same).
  write_all(dir / "spec.txt",
            "nova-compose 1\ntarget three camera=2\n"
            "instance object=1 time=-1\ninstance object=1 time=0.2 translate=0.1,0,0\n"
            "instance object=2 time=0 rotate=0,30,0\n"
            "target edge_on camera=0\ninstance object=1 time=0 rotate=0,90,0\n");
  Result c = nova_cli("render --run " + run + " --out " + (dir / "comp").string() + " --compose " +
                          (dir / "spec.txt").string(), dir);
  BOOST_REQUIRE_MESSAGE(c.code == 0, c.err);
  for (const char* f : {"three.png", "three_depth.png", "three_mask0.png", "three_mask3.png", "edge_on.png"})
    BOOST_TEST(fs::exists(dir / "comp" / f), f);
  // Each instance's pivot and where it came from (none is given: the density, or the origin
  // with a warning where this 9-step run's object has none).
  for (const char* line : {"target three: instance 1 (object 1, t=-1) pivot (", "target three: instance 3 (object 2, t=0) pivot ("})
    BOOST_TEST(c.out.find(line) != std::string::npos, line << " in: " << c.out);
  BOOST_TEST((c.out.find(") from density") != std::string::npos || c.out.find(") from origin") != std::string::npos));

  Result e = nova_cli("eval --run " + run, dir);
  BOOST_REQUIRE_MESSAGE(e.code == 0, e.err);
  const std::string json = read_all(dir / "run" / "eval.json");
  for (const char* key : {"\"mean_psnr\"", "\"mean_ssim\"", "\"compose_mean_psnr\"", "cam0_000"})
    BOOST_TEST(json.find(key) != std::string::npos, key);

  // A composition target that shows nothing (objects alone, none in view: a black truth) is
  // left out of the scores with a note, not scored as a "perfect" 361 dB.
  const fs::path blank = dir / "blank-scene";
  fs::copy(scene, blank, fs::copy_options::recursive);
  {
    const Image8 truth = read_rgb((blank / "gt/compose/objects_only.png").string());
    write_png((blank / "gt/compose/objects_only.png").string(), Image8(truth.width, truth.height, truth.channels, 0));
  }
  Result eb = nova_cli("eval --run " + run + " --scene " + blank.string() + " --views cam0", dir);
  BOOST_REQUIRE_MESSAGE(eb.code == 0, eb.err);
  BOOST_TEST(eb.err.find("composition target objects_only shows nothing") != std::string::npos, eb.err);
  BOOST_TEST(eb.out.find("objects_only") == std::string::npos, eb.out);

  // config.ini names the scene by its absolute path: eval finds it from any folder.
  const std::string config = read_all(dir / "run" / "config.ini");
  BOOST_TEST(config.find("\nscene = " + fs::weakly_canonical(fs::absolute(scene)).string() + "\n") != std::string::npos, config);
  Result elsewhere = run_built("nova", "eval --run " + fs::absolute(run).string() + " --views cam0", dir, "cd / &&");
  BOOST_TEST(elsewhere.code == 0, elsewhere.err);

  // A resume the checkpoint refuses (fewer steps than it has done) leaves config.ini as it was.
  Result shorter = nova_cli("train --out " + run + " --resume --steps 2", dir);
  BOOST_TEST(shorter.code == 2, shorter.err);
  BOOST_TEST(shorter.err.find("does not fit this run") != std::string::npos, shorter.err);
  BOOST_TEST(read_all(dir / "run" / "config.ini") == config);

  // Resume continues the same run to a longer schedule, on the scene config.ini names.
  Result more = nova_cli("train --out " + run + " --resume --steps 9", dir);
  BOOST_REQUIRE_MESSAGE(more.code == 0, more.err);
  BOOST_TEST(more.err.find("resumed at step 9") != std::string::npos);
  BOOST_TEST(read_all(dir / "run" / "config.ini").find("\nsteps = 9\n") != std::string::npos);

  // A pose as 12 numbers with commas, or as separate words (negative ones too, which the
  // option parser would otherwise take for options).
  Result pc = nova_cli("render --run " + run + " --out " + (dir / "pose_commas").string() +
                           " --time 0 --no-masks --pose 1,0,0,0,0,-1,0,0,0,0,-1,-0.5", dir);
  BOOST_TEST(pc.code == 0, pc.err);
  Result pw = nova_cli("render --run " + run + " --out " + (dir / "pose_words").string() +
                           " --time 0 --pose 1 0 0 0 0 -1 0 0 0 0 -1 -0.5 --no-masks", dir);
  BOOST_TEST(pw.code == 0, pw.err);
  Result pg = nova_cli("render --run " + run + " --out " + (dir / "pose_groups").string() +
                           " --time 0 --no-masks --pose 1,0,0,0 0,-1,0,0 0,0,-1,-0.5", dir);
  BOOST_TEST(pg.code == 0, pg.err);
  BOOST_TEST(read_all(dir / "pose_commas" / "000.png") == read_all(dir / "pose_words" / "000.png"));
  BOOST_TEST(read_all(dir / "pose_commas" / "000.png") == read_all(dir / "pose_groups" / "000.png"));
}

// Rigid objects that also deform, each in a box of its own: train, resume, render every frame
// and a composition, and evaluate, all through the deformation network's parameters and the
// objects' boxes in the checkpoint.
BOOST_AUTO_TEST_CASE(deforming_boxed_objects_train_resume_render_and_compose) {
  if (!has_cli()) return;
  TempDir dir("cli-deform");
  const std::string scene = cached_tiny_scene().string(), run = (dir / "run").string();
  const std::string deform = " --object-motion rigid --deform-width 8 --deform-bound 0.1 --object-box true";
  Result t = nova_cli("train --scene " + scene + " --out " + run + kTiny + deform, dir);
  BOOST_REQUIRE_MESSAGE(t.code == 0, t.err);
  BOOST_TEST(read_all(dir / "run" / "config.ini").find("\ndeform-width = 8\n") != std::string::npos);
  BOOST_TEST(read_all(dir / "run" / "config.ini").find("\nobject-box = true\n") != std::string::npos);
  Result more = nova_cli("train --out " + run + " --resume --steps 9", dir);
  BOOST_REQUIRE_MESSAGE(more.code == 0, more.err);
  Result r = nova_cli("render --run " + run + " --out " + (dir / "frames").string() + " --no-masks", dir);
  BOOST_REQUIRE_MESSAGE(r.code == 0, r.err);
  BOOST_TEST(fs::exists(dir / "frames" / "009.png"));
  write_all(dir / "spec.txt", "nova-compose 1\ntarget turned camera=0\ninstance object=1 time=0.3 rotate=0,30,0\n");
  Result c = nova_cli("render --run " + run + " --out " + (dir / "comp").string() + " --compose " +
                          (dir / "spec.txt").string(), dir);
  BOOST_REQUIRE_MESSAGE(c.code == 0, c.err);
  BOOST_TEST(fs::exists(dir / "comp" / "turned.png"));
  Result e = nova_cli("eval --run " + run, dir);
  BOOST_TEST(e.code == 0, e.err);
  // Without the rigid model the option is refused before anything is written.
  Result bad = nova_cli("train --scene " + scene + " --out " + (dir / "bad").string() + kTiny +
                            " --object-motion none --deform-width 8", dir);
  BOOST_TEST(bad.code == 2, bad.err);
  BOOST_TEST(bad.err.find("deform-width") != std::string::npos, bad.err);
  BOOST_TEST(!fs::exists(dir / "bad"));
}

// A run trained with --holdout still renders every frame of its scene folder: --camera and
// the default times count the held-out frames too (10 frames, every 4th held out).
BOOST_AUTO_TEST_CASE(render_counts_held_out_frames) {
  if (!has_cli()) return;
  TempDir dir("cli-holdout");
  const std::string scene = cached_tiny_scene().string(), run = (dir / "run").string();
  Result t = nova_cli("train --scene " + scene + " --out " + run + " --holdout 4" + kTiny, dir);
  BOOST_REQUIRE_MESSAGE(t.code == 0, t.err);
  Result r = nova_cli("render --run " + run + " --out " + (dir / "frames").string() + " --camera 8 --no-masks", dir);
  BOOST_REQUIRE_MESSAGE(r.code == 0, r.err);
  for (const char* f : {"000.png", "004.png", "009.png"}) BOOST_TEST(fs::exists(dir / "frames" / f), f);
  BOOST_TEST(!fs::exists(dir / "frames" / "010.png"));
  Result bad = nova_cli("render --run " + run + " --out " + (dir / "none").string() + " --camera 10", dir);
  BOOST_TEST(bad.code == 2);
  BOOST_TEST(bad.err.find("the scene has frames 0..9") != std::string::npos, bad.err);
  // The held-out frames carry their masks: nova eval scores the objects and the background
  // apart there (the scene's held-out cameras have no masks and get no such scores).
  Result e = nova_cli("eval --run " + run + " --views heldout", dir);
  BOOST_REQUIRE_MESSAGE(e.code == 0, e.err);
  BOOST_TEST(e.out.find("objects  background  opacity") != std::string::npos, e.out);
  BOOST_TEST(e.out.find("inside the objects' masks") != std::string::npos, e.out);
  BOOST_TEST(e.out.find("the objects render") != std::string::npos, e.out);
  const std::string json = read_all(dir / "run" / "eval.json");
  const size_t frame = json.find("\"frame_004\"");
  BOOST_REQUIRE(frame != std::string::npos);
  BOOST_TEST(json.find("\"object_psnr\"", frame) < json.find("}", frame), json);
  BOOST_TEST(json.find("\"object_opacity\"", frame) < json.find("}", frame), json);
  BOOST_TEST(json.find("\"mean_object_psnr\": ") != std::string::npos);
  BOOST_TEST(json.find("\"mean_object_psnr\": null") == std::string::npos);
  // The objects' masks summed inside their region: an opacity, so within [0, 1].
  const std::string key = "\"mean_object_opacity\": ";
  const size_t at = json.find(key);
  BOOST_REQUIRE_MESSAGE(at != std::string::npos, json);
  const double opacity = std::stod(json.substr(at + key.size()));
  BOOST_TEST(opacity > 0.0);
  BOOST_TEST(opacity <= 1.0 + 1e-6);
}

BOOST_AUTO_TEST_CASE(bad_inputs_exit_2_and_leave_nothing) {
  if (!has_cli()) return;
  TempDir dir("cli-bad");
  const std::string scene = cached_tiny_scene().string();
  const std::string out = (dir / "run").string();
  const auto expect = [&](const std::string& args, const std::string& needle) {
    Result r = nova_cli(args, dir);
    BOOST_TEST(r.code == 2, args << " -> exit " << r.code << ": " << r.err);
    BOOST_TEST(r.err.find(needle) != std::string::npos, args << ": '" << needle << "' not in: " << r.err);
  };
  expect("train --scene " + (dir / "nowhere").string() + " --out " + out + kTiny, "nowhere");
  BOOST_TEST(!fs::exists(out));
  expect("train --scene " + scene + " --out " + out + " --rays abc", "'rays'");
  expect("train --scene " + scene + " --out " + out + " --samples 0", "out of range");
  expect("train --scene " + scene + " --out " + out + " --preset huge", "'huge'");
  expect("train --scene " + scene + " --out " + out + " --depth 2 --skip 4", "skip");
  write_all(dir / "bad.ini", "rays = 64\nlr = fast\n");
  expect("train --scene " + scene + " --out " + out + " --config " + (dir / "bad.ini").string(), "'lr'");
  write_all(dir / "unknown.ini", "wings = 2\n");
  expect("train --scene " + scene + " --out " + out + " --config " + (dir / "unknown.ini").string(), "wings");
  BOOST_TEST(!fs::exists(out));
  expect("train --scene " + scene + " --out " + out + " --resume" + kTiny, "checkpoint");

  // A trained run for the render errors.
  BOOST_REQUIRE(nova_cli("train --scene " + scene + " --out " + out + kTiny, dir).code == 0);
  expect("train --scene " + scene + " --out " + out + kTiny, "already exists");
  write_all(dir / "spec.txt", "nova-compose 1\ntarget t camera=0\ninstance object=7 time=0\n");
  expect("render --run " + out + " --out " + (dir / "comp").string() + " --compose " + (dir / "spec.txt").string(),
         "object 7");
  BOOST_TEST(!fs::exists(dir / "comp"));
  BOOST_TEST(!fs::exists(dir / "comp.partial"));
  expect("render --run " + out + " --out " + (dir / "r").string() + " --camera 99", "--camera 99");
  expect("render --run " + out + " --out " + (dir / "r").string() + " --pose 1,2,3", "got 3");
  expect("render --run " + out + " --out " + (dir / "r").string() + " --pose 1,0,0,0,0,1,0,0,0,0,1,nan", "'nan'");
  expect("render --run " + out + " --out " + (dir / "r").string() + " --pose 0,0,0,0,0,0,0,0,0,0,0,0", "not a rotation");
  expect("render --run " + out + " --out " + (dir / "r").string() + " --pose 2,0,0,0,0,1,0,0,0,0,1,0", "not a rotation");
  expect("render --run " + out + " --out " + (dir / "r").string() + " --camera 1 --pose 1,0,0,0,0,1,0,0,0,0,1,0",
         "--camera and --pose");
  expect("render --run " + out + " --out " + (dir / "r").string() + " --pose 1,0,0,0,0,1 --pose 0,0,0,0,1,0",
         "more than once");
  expect("render --run " + out + " --out " + (dir / "r").string() + " --time 0 stray", "unexpected argument 'stray'");
  expect("render --run " + out + " --out " + (dir / "r").string() + " --time 3", "--time");
  expect("render --run " + out + " --out " + (dir / "r").string() + " --fps 30", "--fps");
  expect("render --run " + out + " --out " + (dir / "r").string() + " --video --fps 0", "--fps 0");
  write_all(dir / "ok.txt", "nova-compose 1\ntarget t camera=0\ninstance object=1 time=0\n");
  expect("render --run " + out + " --out " + (dir / "r").string() + " --compose " + (dir / "ok.txt").string() +
             " --time 0", "--time does not apply to --compose");
  write_all(dir / "late.txt", "nova-compose 1\ntarget t camera=0\ninstance object=1 time=3\n");
  expect("render --run " + out + " --out " + (dir / "r").string() + " --compose " + (dir / "late.txt").string(),
         "time must be in [-1, 1]");
  expect("eval --run " + out + " --views cam0 --split test", "--views and --split");
  expect("eval --run " + out + " --split test", "has no splits");
  // An --out below a file is refused before any work, for every command that writes one.
  write_all(dir / "afile", "x");
  const std::string below = (dir / "afile" / "x").string();
  expect("render --run " + out + " --out " + below, "is not a folder");
  expect("train --scene " + scene + " --out " + below + kTiny, "is not a folder");
  expect("synth --preset tiny --out " + below, "is not a folder");
  expect("synth --preset tiny --seed -1 --out " + (dir / "s").string(), "--seed -1");
  expect("train --scene " + scene + " --out " + (dir / "f").string() + " --factor 64" + kTiny, "--factor 64");
  BOOST_TEST(!fs::exists(dir / "f"));
  BOOST_TEST(!fs::exists(dir / "s"));
  expect("train --scene " + scene + " --out " + (dir / "h").string() + " --holdout 1" + kTiny, "to train on");
  // Without density noise a hash grid can start dead: allowed, with a warning.
  Result quiet = nova_cli("train --scene " + scene + " --out " + (dir / "nz").string() + kTiny + " --noise-std 0", dir);
  BOOST_TEST(quiet.code == 0, quiet.err);
  BOOST_TEST(quiet.err.find("warning: --noise-std 0 with the hash-grid encoding") != std::string::npos, quiet.err);
  BOOST_TEST(!fs::exists(dir / "h"));
  // A NOVA-layout folder without motion_masks/: refused with the way out, which works and
  // which render then reads back from config.ini.
  const fs::path unmasked = dir / "unmasked";
  fs::copy(scene, unmasked, fs::copy_options::recursive);
  fs::remove_all(unmasked / "motion_masks");
  expect("train --scene " + unmasked.string() + " --out " + (dir / "u").string() + kTiny, "--static-only true");
  BOOST_TEST(!fs::exists(dir / "u"));
  Result u = nova_cli("train --scene " + unmasked.string() + " --out " + (dir / "u").string() + kTiny +
                          " --static-only true", dir);
  BOOST_TEST(u.code == 0, u.err);
  BOOST_TEST(read_all(dir / "u" / "config.ini").find("\nstatic-only = true\n") != std::string::npos);
  Result ur = nova_cli("render --run " + (dir / "u").string() + " --out " + (dir / "ur").string() + " --time 0", dir);
  BOOST_TEST(ur.code == 0, ur.err);
  BOOST_TEST(fs::exists(dir / "ur" / "000_mask0.png"));
  BOOST_TEST(!fs::exists(dir / "ur" / "000_mask1.png"));  // one NeRF: the static one

  // Object masks that leave no background pixel anywhere: refused before training.
  const fs::path covered = dir / "covered";
  fs::copy(scene, covered, fs::copy_options::recursive);
  for (const auto& f : fs::directory_iterator(covered / "motion_masks" / "1")) {
    const Image8 m = read_mask(f.path().string());
    write_png(f.path().string(), Image8(m.width, m.height, 1, 255));
  }
  expect("train --scene " + covered.string() + " --out " + (dir / "c").string() + kTiny, "no background pixel");
  BOOST_TEST(!fs::exists(dir / "c"));
  expect("train --scene " + scene + " --out " + (dir / "e").string() + kTiny + " --adam-eps 0", "adam-eps");

  // With --factor the scene's ground truth is downscaled as its frames are: eval scores it.
  Result half = nova_cli("train --scene " + scene + " --out " + (dir / "half").string() + kTiny + " --factor 2", dir);
  BOOST_TEST(half.code == 0, half.err);
  Result half_eval = nova_cli("eval --run " + (dir / "half").string() + " --views all", dir);
  BOOST_TEST(half_eval.code == 0, half_eval.err);
  // The composition targets are scored, inside their instances first (the synthetic truth
  // gives where they are), with how opaque the instances render there.
  BOOST_TEST(half_eval.out.find("composition targets: inside the instances ") != std::string::npos, half_eval.out);
  BOOST_TEST(half_eval.out.find(" opaque), mean PSNR ") != std::string::npos, half_eval.out);
  expect("render --run " + (dir / "norun").string() + " --out " + (dir / "r").string(), "norun");
  expect("eval --run " + out + " --views sideways", "sideways");
  // A damaged checkpoint is named as such.
  std::string bytes = read_all(fs::path(out) / "checkpoint.bin");
  bytes[bytes.size() / 2] ^= 0x33;
  write_all(fs::path(out) / "checkpoint.bin", bytes);
  expect("render --run " + out + " --out " + (dir / "r").string(), "corrupt");
  BOOST_TEST(!fs::exists(dir / "r"));
}

BOOST_AUTO_TEST_SUITE_END()

}  // namespace nova::test

// nova-bench accuracy: the scene list (sets expand, duplicates go, unknown names are errors),
// the per-set aggregates on given numbers, the CSV and JSON read back; then the command on a
// tiny synthetic scene with tiny networks (a run, a --reuse run that trains nothing and scores
// the same) and its bad inputs (exit 2, one line naming the input, nothing written); a family
// scene started from the generator's exact motion and kept there (--exact-motion).
#include <boost/test/unit_test.hpp>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <sys/wait.h>

#include "../bench/accuracy.hpp"
#include "../bench/family_truth.hpp"
#include "nova/data/scene_io.hpp"
#include "nova/model/checkpoint.hpp"
#include "nova/model/field_graphs.hpp"
#include "nova/train/motion_init.hpp"
#include "nova/io/image_io.hpp"
#include "scene_test_util.hpp"

namespace nova::test {
namespace {
using namespace nova::accuracy;

std::vector<std::string> names(const std::vector<SceneSpec>& specs) {
  std::vector<std::string> out;
  for (const SceneSpec& s : specs) out.push_back(s.name);
  return out;
}

std::string error_of(const std::string& list) {
  try {
    parse_scene_list(list);
  } catch (const Error& e) {
    BOOST_TEST(e.exit_code() == kExitUsage);
    return e.what();
  }
  BOOST_ERROR("no error for '" << list << "'");
  return "";
}

SceneResult result(const std::string& name, const std::string& set, double cam0, double held, double comp, double train,
                   const std::string& status = "ok") {
  SceneResult r;
  r.name = name, r.set = set, r.cam0_psnr = cam0, r.heldout_psnr = held, r.compose_psnr = comp, r.train_s = train;
  r.status = status;
  r.steps = 100;
  return r;
}

using Result = CommandResult;

Result bench_cli(const std::string& args, const TempDir& dir) { return run_built("nova-bench", "accuracy " + args, dir); }

bool has_bench() { return fs::exists(fs::path(NOVA_BINARY_DIR) / "nova-bench"); }

// Tiny networks and schedule (as test_tradeoff's): seconds per run on 2 PoCL cores.
const std::string kTiny =
    " --set hash-levels=4 --set hash-log2-size=10 --set hash-max-res=32 --set depth=2 --set width=16 --set skip=-1"
    " --set rays=64 --set samples=8 --set pretrain-steps=3 --set steps=6 --set augment-start=0 --set log-every=3";

}  // namespace

BOOST_AUTO_TEST_SUITE(accuracy)

BOOST_AUTO_TEST_CASE(scene_lists_expand_sets_and_drop_duplicates) {
  BOOST_TEST(names(parse_scene_list("dev")) == (std::vector<std::string>{"family:1", "family:2", "family:3", "family:4"}),
             boost::test_tools::per_element());
  BOOST_TEST(names(parse_scene_list("test")) ==
                 (std::vector<std::string>{"family:101", "family:102", "family:103", "family:104"}),
             boost::test_tools::per_element());
  BOOST_TEST(parse_scene_list("all").size() == 11u);
  // Duplicates (also through a set, or a seed written differently) are dropped, first mention kept.
  const auto mixed = parse_scene_list("family:3, dev,balloon,synth:tiny:00,synth:tiny:0,real,family:003");
  BOOST_TEST(names(mixed) == (std::vector<std::string>{"family:3", "family:1", "family:2", "family:4", "balloon",
                                                       "synth:tiny:0", "fern", "lego"}),
             boost::test_tools::per_element());
  // Named directly or only through a set (a missing data folder is an error only for the former).
  BOOST_TEST(mixed[0].named);
  BOOST_TEST(!mixed[1].named);
  BOOST_TEST(mixed[4].named);
  BOOST_TEST(!mixed[6].named);
  BOOST_TEST(parse_scene_list("real,lego").back().named);
  // Sets and protocols.
  BOOST_TEST(parse_scene("family:2").set == "dev");
  BOOST_TEST(parse_scene("family:104").set == "test");
  BOOST_TEST(parse_scene("family:7").set == "other");
  BOOST_TEST(parse_scene("synth:default:1").set == "other");
  BOOST_TEST(parse_scene("synth:deforming:101").set == "deforming");
  BOOST_TEST(names(parse_scene_list("deforming")) ==
                 (std::vector<std::string>{"synth:deforming:101", "synth:deforming:102", "synth:deforming:103",
                                           "synth:deforming:104"}),
             boost::test_tools::per_element());
  const SceneSpec f = parse_scene("family:101");
  BOOST_TEST(f.synthetic);
  BOOST_TEST(f.preset == "family");
  BOOST_TEST(f.seed == 101u);
  BOOST_TEST(f.dir_name() == "family-101");
  const SceneSpec b = parse_scene("balloon");
  BOOST_TEST(b.folder == "nvidia_balloon1");
  BOOST_TEST((b.protocol == std::vector<std::pair<std::string, std::string>>{{"factor", "4"}, {"holdout", "4"}}));
  BOOST_TEST((parse_scene("fern").protocol == std::vector<std::pair<std::string, std::string>>{{"holdout", "8"}}));
  BOOST_TEST(parse_scene("lego").protocol.empty());
  BOOST_TEST(parse_scene("lego").eval_split == "test");
  BOOST_TEST(parse_scene("synth:tiny:5").preset == "tiny");
}

BOOST_AUTO_TEST_CASE(unknown_scenes_are_errors_naming_them) {
  BOOST_TEST(error_of("dev,moon").find("unknown scene 'moon'") != std::string::npos);
  BOOST_TEST(error_of("Dev").find("'Dev'") != std::string::npos);
  BOOST_TEST(error_of("synth:tiny").find("'synth:tiny'") != std::string::npos);
  BOOST_TEST(error_of("family:x").find("seed 'x'") != std::string::npos);
  BOOST_TEST(error_of("family:-1").find("'family:-1'") != std::string::npos);
  BOOST_TEST(error_of("family:99999999999").find("seed") != std::string::npos);
  BOOST_TEST(error_of(" , ").find("names no scene") != std::string::npos);
}

BOOST_AUTO_TEST_CASE(aggregates_per_set) {
  const std::vector<SceneResult> rs = {
      result("family:1", "dev", 20, 18, 17, 10),
      result("family:2", "dev", 24, 20, kNaN, 30),
      result("family:3", "dev", 22, 22, 19, 20),
      result("family:4", "dev", 5, 5, 5, 1000, "failed: diverged"),  // counts nowhere
      result("family:101", "test", 26, 21, 23, 15, "reused"),
      result("balloon", "real", kNaN, 18.5, kNaN, 40),
  };
  const std::vector<SetSummary> s = aggregate(rs);
  BOOST_REQUIRE(s.size() == 4u);
  BOOST_TEST(s[0].set == "dev");
  BOOST_TEST(s[0].scenes == 3);
  BOOST_TEST(s[0].mean_cam0_psnr == 22.0, boost::test_tools::tolerance(1e-12));
  BOOST_TEST(s[0].min_cam0_psnr == 20.0);
  BOOST_TEST(s[0].mean_heldout_psnr == 20.0, boost::test_tools::tolerance(1e-12));
  BOOST_TEST(s[0].mean_compose_psnr == 18.0, boost::test_tools::tolerance(1e-12));  // NaN left out
  BOOST_TEST(s[0].total_train_s == 60.0, boost::test_tools::tolerance(1e-12));
  BOOST_TEST(s[1].set == "test");
  BOOST_TEST(s[1].mean_cam0_psnr == 26.0);
  BOOST_TEST(s[2].set == "real");
  BOOST_TEST(std::isnan(s[2].mean_cam0_psnr));
  BOOST_TEST(std::isnan(s[2].min_cam0_psnr));
  BOOST_TEST(s[2].mean_heldout_psnr == 18.5);
  BOOST_TEST(s[3].set == "all");
  BOOST_TEST(s[3].scenes == 5);
  BOOST_TEST(s[3].mean_cam0_psnr == 23.0, boost::test_tools::tolerance(1e-12));
  BOOST_TEST(s[3].min_cam0_psnr == 20.0);
  BOOST_TEST(s[3].total_train_s == 115.0, boost::test_tools::tolerance(1e-12));
  // One set: no "all" row.
  BOOST_TEST(aggregate({rs[0], rs[1]}).size() == 1u);
  BOOST_TEST(rs[5].psnr() == 18.5);  // held-out where there is no camera 0
  BOOST_TEST(rs[0].psnr() == 20.0);
}

BOOST_AUTO_TEST_CASE(csv_and_json_read_back) {
  std::vector<SceneResult> rs = {result("family:1", "dev", 20.12346, 18.5, 17.25, 10.5),
                                 result("lego", "real", kNaN, 20.47, kNaN, 72.25, "failed: a, \"b\"")};
  rs[0].cam0_ssim = 0.81234;
  rs[0].cam0_views = 24;
  rs[0].heldout_views = 48;
  rs[0].compose_views = 3;
  rs[0].eval_s = 4.25;
  rs[1].heldout_views = 20;
  rs[1].heldout_object_psnr = 16.12346, rs[1].heldout_background_psnr = 22.5;
  rs[0].cam0_object_psnr = 15.25, rs[0].cam0_background_psnr = 21.0;
  rs[0].compose_object_psnr = 14.5;
  rs[0].cam0_object_opacity = 0.875;
  const std::vector<SetSummary> sets = aggregate(rs);
  const std::string csv = csv_text(rs, sets);
  std::vector<SceneResult> back;
  std::vector<SetSummary> back_sets;
  parse_csv(csv, &back, &back_sets);
  BOOST_REQUIRE(back.size() == 2u);
  BOOST_REQUIRE(back_sets.size() == sets.size());
  BOOST_TEST(back[0].name == "family:1");
  BOOST_TEST(back[0].cam0_psnr == 20.1235, boost::test_tools::tolerance(1e-9));  // 4 decimals
  BOOST_TEST(back[0].cam0_ssim == 0.81234, boost::test_tools::tolerance(1e-9));
  BOOST_TEST(back[0].eval_s == 4.25);
  BOOST_TEST(back[0].cam0_views == 24);
  BOOST_TEST(back[0].compose_views == 3);
  BOOST_TEST(back[0].steps == 100);
  BOOST_TEST(std::isnan(back[1].cam0_psnr));
  BOOST_TEST(back[1].status == "failed: a, \"b\"");
  BOOST_TEST(back[1].heldout_views == 20);
  BOOST_TEST(back_sets[0].set == "dev");
  BOOST_TEST(back_sets[0].mean_cam0_psnr == 20.1235, boost::test_tools::tolerance(1e-9));
  // The objects' PSNR travels in the CSV too (the background's only in the JSON).
  BOOST_TEST(back[0].cam0_object_psnr == 15.25);
  BOOST_TEST(back[0].compose_object_psnr == 14.5);
  BOOST_TEST(back[1].heldout_object_psnr == 16.1235, boost::test_tools::tolerance(1e-9));
  BOOST_TEST(back_sets[0].mean_cam0_object_psnr == 15.25);
  BOOST_TEST(back_sets[0].mean_compose_object_psnr == 14.5);
  BOOST_TEST(csv_text(back, back_sets) == csv);  // a fixed point
  BOOST_CHECK_THROW(parse_csv("kind,name\n", &back, &back_sets), Error);
  BOOST_CHECK_THROW(parse_csv(std::string(kCsvHeader) + "\nscene,x\n", &back, &back_sets), Error);

  const nlohmann::json t = nlohmann::json::parse(json_text({{"preset", "quick"}, {"set steps", "30"}}, rs, sets));
  BOOST_TEST(t.at("configuration").at("preset").get<std::string>() == "quick");
  BOOST_TEST(t.at("configuration").at("set steps").get<std::string>() == "30");
  const nlohmann::json& scenes = t.at("scenes");
  BOOST_REQUIRE(scenes.size() == 2u);
  BOOST_TEST(scenes[0].at("name").get<std::string>() == "family:1");
  BOOST_TEST(scenes[0].at("cam0_psnr").get<double>() == 20.1235, boost::test_tools::tolerance(1e-9));
  BOOST_TEST(scenes[0].at("train_seconds").get<double>() == 10.5);
  BOOST_TEST(scenes[0].at("steps").is_number_integer());
  BOOST_TEST(scenes[1].at("cam0_psnr").is_null());
  BOOST_TEST(scenes[1].at("status").get<std::string>() == "failed: a, \"b\"");
  BOOST_TEST(scenes[1].at("heldout_psnr").get<double>() == 20.47, boost::test_tools::tolerance(1e-9));
  BOOST_TEST(scenes[1].at("heldout_object_psnr").get<double>() == 16.1235, boost::test_tools::tolerance(1e-9));
  BOOST_TEST(scenes[1].at("heldout_background_psnr").get<double>() == 22.5, boost::test_tools::tolerance(1e-9));
  BOOST_TEST(scenes[0].at("heldout_object_psnr").is_null());
  BOOST_TEST(scenes[0].at("cam0_object_psnr").get<double>() == 15.25);
  BOOST_TEST(scenes[1].at("cam0_background_psnr").is_null());
  BOOST_TEST(scenes[0].at("cam0_object_opacity").get<double>() == 0.875);
  BOOST_TEST(scenes[0].at("heldout_object_opacity").is_null());
  std::vector<std::string> set_names;
  for (const auto& v : t.at("sets")) set_names.push_back(v.at("set").get<std::string>());
  BOOST_TEST(set_names == (std::vector<std::string>{"dev", "real", "all"}), boost::test_tools::per_element());
  const std::string table = table_text(rs, sets);
  BOOST_TEST(table.find("family:1") != std::string::npos);
  BOOST_TEST(table.find("20.12") != std::string::npos);
}

BOOST_AUTO_TEST_CASE(runs_on_a_tiny_synthetic_scene) {
  if (!has_bench()) return;
  TempDir dir("accuracy-run");
  const std::string out = (dir / "a").string();
  const Result r = bench_cli("--scenes synth:tiny:3 --out " + out + kTiny, dir);
  BOOST_REQUIRE_MESSAGE(r.code == 0, r.err);
  for (const char* f : {"accuracy.csv", "accuracy.json", "accuracy.png", "pictures/synth-tiny-3.png",
                        "scenes/synth-tiny-3/synth.txt", "runs/synth-tiny-3/config.ini", "runs/synth-tiny-3/checkpoint.bin"})
    BOOST_TEST(fs::exists(fs::path(out) / f), f);
  BOOST_TEST(r.err.find("[1/1] synth:tiny:3 (other)") != std::string::npos, r.err);
  BOOST_TEST(r.err.find("step       9/9") != std::string::npos, r.err);  // the trainer's own progress lines
  std::vector<SceneResult> rs;
  std::vector<SetSummary> sets;
  parse_csv(read_all(fs::path(out) / "accuracy.csv"), &rs, &sets);
  BOOST_REQUIRE(rs.size() == 1u);
  BOOST_TEST(rs[0].status == "ok");
  BOOST_TEST(rs[0].steps == 9);
  BOOST_TEST(rs[0].cam0_views == 10);     // camera 0 at every time of the tiny scene
  BOOST_TEST(rs[0].heldout_views == 20);  // two held-out cameras
  BOOST_TEST(rs[0].compose_views > 0);
  BOOST_TEST(std::isfinite(rs[0].cam0_psnr));
  BOOST_TEST(rs[0].cam0_psnr > 5.0);
  BOOST_TEST(rs[0].train_s > 0.0);
  BOOST_TEST(r.out.find("synth:tiny:3") != std::string::npos, r.out);
  // The synthetic ground truth carries its objects regions: camera 0 and the composition
  // targets are scored inside and outside them (accuracy.json, the CSV and the progress line).
  const nlohmann::json scene = nlohmann::json::parse(read_all(fs::path(out) / "accuracy.json")).at("scenes").at(0);
  BOOST_TEST(scene.at("cam0_object_psnr").get<double>() > 5.0);
  BOOST_TEST(scene.at("cam0_background_psnr").get<double>() > 5.0);
  BOOST_TEST(scene.at("cam0_object_opacity").get<double>() > 0.0);
  BOOST_TEST(scene.at("cam0_object_opacity").get<double>() <= 1.0 + 1e-6);
  BOOST_TEST(r.err.find("PSNR camera 0 ") != std::string::npos);
  BOOST_TEST(r.err.find("PSNR camera 0 objects ") != std::string::npos, r.err);
  BOOST_TEST(std::isfinite(rs[0].compose_object_psnr));
  BOOST_TEST(rs[0].compose_object_psnr > 5.0);
  const Image8 pic = read_rgb((fs::path(out) / "pictures/synth-tiny-3.png").string());
  BOOST_TEST(pic.width >= 6 * 64);  // three times, render and truth
  BOOST_TEST(read_rgb((fs::path(out) / "accuracy.png").string()).width == 1000);

  // --reuse: the finished run is kept (no training) and scores the same.
  const Result again = bench_cli("--scenes synth:tiny:3 --reuse --out " + out + kTiny, dir);
  BOOST_REQUIRE_MESSAGE(again.code == 0, again.err);
  BOOST_TEST(again.err.find("reusing the finished run") != std::string::npos, again.err);
  BOOST_TEST(again.err.find("step       9/9") == std::string::npos, again.err);
  std::vector<SceneResult> rs2;
  parse_csv(read_all(fs::path(out) / "accuracy.csv"), &rs2, &sets);
  BOOST_REQUIRE(rs2.size() == 1u);
  BOOST_TEST(rs2[0].status == "reused");
  BOOST_TEST(rs2[0].cam0_psnr == rs[0].cam0_psnr);
  BOOST_TEST(rs2[0].train_s == rs[0].train_s);
  // Another configuration is trained again.
  const Result other = bench_cli("--scenes synth:tiny:3 --reuse --out " + out + kTiny + " --set seed=2", dir);
  BOOST_REQUIRE_MESSAGE(other.code == 0, other.err);
  BOOST_TEST(other.err.find("reusing") == std::string::npos, other.err);
}

BOOST_AUTO_TEST_CASE(bad_inputs_exit_2_and_write_nothing) {
  if (!has_bench()) return;
  TempDir dir("accuracy-bad");
  const std::string out = (dir / "a").string();
  const auto expect = [&](const std::string& args, const std::string& needle) {
    const Result r = bench_cli("--out " + out + " " + args, dir);
    BOOST_TEST(r.code == 2, args << " -> exit " << r.code << ": " << r.err);
    BOOST_TEST(r.err.find(needle) != std::string::npos, args << ": '" << needle << "' not in: " << r.err);
    BOOST_TEST(std::count(r.err.begin(), r.err.end(), '\n') == 1, "one line: " << r.err);
    BOOST_TEST(!fs::exists(out), args);
  };
  expect("--scenes synth:tiny:0,moon", "unknown scene 'moon'");
  expect("--scenes synth:nosuch:0", "scene 'synth:nosuch:0'");
  expect("--scenes synth:tiny:0 --set wings=2", "--set 'wings=2'");
  expect("--scenes synth:tiny:0 --set steps=many", "--set 'steps=many'");
  expect("--scenes synth:tiny:0 --set steps", "--set 'steps'");
  expect("--scenes synth:tiny:0 --preset fast", "fast");
  expect("--scenes synth:tiny:0 --config " + (dir / "none.ini").string(), "none.ini");
  expect("--scenes lego --data " + (dir / "no-data").string(), "scene 'lego'");
  expect("--scenes synth:tiny:0 --frobnicate 1", "--frobnicate");
  // A real scene reached only through a set is skipped with a note; --dry-run writes nothing.
  const Result d = bench_cli("--out " + out + " --scenes real,synth:tiny:0 --dry-run --data " + (dir / "no-data").string(), dir);
  BOOST_TEST(d.code == 0, d.err);
  BOOST_TEST(d.out.find("skipped balloon") != std::string::npos, d.out);
  BOOST_TEST(!fs::exists(out));
  // The family's sets plan like any synthetic scene (their size comes from the seed).
  const Result f = bench_cli("--out " + out + " --scenes dev,test --dry-run", dir);
  BOOST_TEST(f.code == 0, f.err);
  BOOST_TEST(f.out.find("family:1") != std::string::npos, f.out);
  BOOST_TEST(f.out.find("family:104") != std::string::npos, f.out);
  BOOST_TEST(!fs::exists(out));
}

BOOST_AUTO_TEST_CASE(exact_motion_starts_from_the_generators_motion) {
  if (!has_bench()) return;
  TempDir dir("accuracy-exact");
  const std::string out = (dir / "a").string();
  // lr-motion 0 keeps the start, so the trained trajectory is the start itself.
  const Result r = bench_cli("--scenes family:1 --exact-motion --set lr-motion=0 --out " + out + kTiny, dir);
  BOOST_REQUIRE_MESSAGE(r.code == 0, r.err);
  BOOST_TEST(fs::exists(fs::path(out) / "runs/family-1/exact_motion.txt"));
  BOOST_TEST(read_all(fs::path(out) / "accuracy.json").find("\"exact-motion\": \"on\"") != std::string::npos);
  const Scene scene = load_scene((fs::path(out) / "scenes/family-1").string());
  const SynthWorld world("family", 1);
  const std::vector<float> rows = read_checkpoint((fs::path(out) / "runs/family-1/checkpoint.bin").string()).array("objects.motion").values;
  const int F = int(scene.frames.size());
  BOOST_REQUIRE(rows.size() == size_t(world.objects()) * size_t(F) * 6);
  const std::vector<int> object = bench::match_objects(scene, world);
  const bench::LoadedWorld loaded = bench::loaded_world(scene, world);
  for (int k = 1; k <= world.objects(); ++k) {
    const float* m = rows.data() + size_t(object[size_t(k)] - 1) * size_t(F) * 6;
    const Pose34 p0 = world.object_pose(k, frame_time(0, F));
    for (int b = 1; b < F; ++b) {
      // The trajectory turns the object from frame 0 to frame b by the generator's turn: the
      // angles agree without any frame transform (a change of frame keeps a turn's angle), and
      // it carries the true centre of frame 0 to that of frame b. Rows are float32: 1e-3
      // degrees and 1e-5 scene units allow their rounding (angles about 1 rad, positions about
      // 3 units: 1e-7 relative) carried through the Euler matrices.
      const Pose34 pb = world.object_pose(k, frame_time(b, F));
      const Mat3 truth = bench::multiply(bench::rotation_of(pb), bench::transpose(bench::rotation_of(p0)));
      const Mat34 ma = motion_matrix(m, F, frame_time(0, F)), mb = motion_matrix(m, F, frame_time(b, F));
      const Mat34 carry = compose_rigid(invert_rigid(mb), ma);  // world at frame 0 -> world at frame b
      BOOST_TEST(std::abs(bench::turn_degrees(bench::rotation_of(carry)) - bench::turn_degrees(truth)) < 1e-3, "object " << k << " frame " << b);
      const Vec3 c0 = apply_rigid(loaded.point, {p0[3], p0[7], p0[11]});
      const Vec3 cb = apply_rigid(loaded.point, {pb[3], pb[7], pb[11]});
      const Vec3 moved = apply_rigid(carry, c0);
      BOOST_TEST(std::hypot(moved[0] - cb[0], moved[1] - cb[1], moved[2] - cb[2]) < 1e-5, "object " << k << " frame " << b);
    }
  }
  // Each canonical box stands about the pivot of the rows it is read with (the mean of their
  // translations), not of the frames' alignment, whose path can run a radius or more off:
  // the box centre is the pivot's NDC image, float32-rounded (1e-5 at coordinates about 1).
  const std::vector<float> boxes = read_checkpoint((fs::path(out) / "runs/family-1/checkpoint.bin").string()).array("objects.box").values;
  BOOST_REQUIRE(boxes.size() == size_t(world.objects()) * 6);
  for (int k = 1; k <= world.objects(); ++k) {
    const size_t m = size_t(object[size_t(k)] - 1);
    const std::array<float, 6> expected = object_box_row(motion_pivot(rows.data() + m * size_t(F) * 6, F), 1.0, ray_geometry(scene));
    for (size_t d = 0; d < 3; ++d) BOOST_TEST(std::fabs(boxes[m * 6 + d] - expected[d]) < 1e-5, "object " << k << " axis " << d);
  }
  // Only family scenes know their motion, and only rigid objects take it: exit 2, one line,
  // nothing written.
  for (const auto& [args, needle] : std::vector<std::pair<std::string, std::string>>{
           {"--scenes synth:tiny:0 --exact-motion", "needs family:SEED scenes"},
           {"--scenes family:1 --exact-motion --set object-motion=none", "needs 'object-motion rigid'"}}) {
    const std::string bad = (dir / "b").string();
    const Result e = bench_cli("--out " + bad + " " + args, dir);
    BOOST_TEST(e.code == 2, args << ": " << e.err);
    BOOST_TEST(e.err.find(needle) != std::string::npos, args << ": " << e.err);
    BOOST_TEST(std::count(e.err.begin(), e.err.end(), '\n') == 1, e.err);
    BOOST_TEST(!fs::exists(bad));
  }
}

BOOST_AUTO_TEST_SUITE_END()

}  // namespace nova::test

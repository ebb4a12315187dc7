// nova-bench tradeoff: settings parsing and its errors, budgets and evaluation points, the
// equal-PSNR speedup on curves whose answer is known exactly (and the n/a case), the CSV and
// the plot; then the command itself on the tiny synthetic scene with a few steps, and its
// bad inputs (exit code 2, one line naming the input, nothing left behind).
#include <boost/test/unit_test.hpp>
#include <cstdlib>
#include <sys/wait.h>

#include "../bench/tradeoff.hpp"
#include "nova/io/image_io.hpp"
#include "nova/io/charts.hpp"
#include "scene_test_util.hpp"

namespace nova::test {
namespace {
using namespace nova::tradeoff;

std::vector<Point> curve(const std::vector<std::pair<double, double>>& xy) {
  std::vector<Point> out;
  for (size_t i = 0; i < xy.size(); ++i) out.push_back({static_cast<int>(i), long(i) * 10, xy[i].first, xy[i].second, 0, 0});
  return out;
}

template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    BOOST_TEST(e.exit_code() == kExitUsage);
    return e.what();
  }
  BOOST_FAIL("no error");
  return "";
}

using Result = CommandResult;

Result bench_cli(const std::string& args, const TempDir& dir) { return run_built("nova-bench", "tradeoff " + args, dir); }

bool has_bench() { return fs::exists(fs::path(NOVA_BINARY_DIR) / "nova-bench"); }

// The tiny networks and schedule of test_cli_run (small hash tables, 3 + 6 steps).
const std::string kTinyBase =
    "hash-levels=4,hash-log2-size=10,hash-max-res=32,depth=2,width=16,skip=-1,rays=64,samples=8,"
    "pretrain-steps=3,steps=6,augment-start=0,log-every=3";

}  // namespace

BOOST_AUTO_TEST_SUITE(tradeoff)

BOOST_AUTO_TEST_CASE(settings_parse) {
  const Setting s = parse_setting("  w-128.b : width = 128, samples=64 ,gemm=kernels ");
  BOOST_TEST(s.name == "w-128.b");
  BOOST_REQUIRE(s.overrides.size() == 2u);
  BOOST_TEST(s.overrides[0].first == "width");
  BOOST_TEST(s.overrides[0].second == "128");
  BOOST_TEST(s.overrides[1].first == "samples");
  BOOST_TEST(s.gemm == "kernels");
  BOOST_TEST(parse_setting("quick").overrides.empty());
  BOOST_TEST(parse_setting("k:NOVA_GEMM=clblast").gemm == "clblast");
  BOOST_TEST(parse_setting("k:gemm=tuned").gemm == "tuned");
  BOOST_TEST(parse_setting("d:--samples=16").overrides[0].first == "samples");  // a flag's spelling

  const auto settings = parse_settings_text("# comment\n\nbase\n  fast: samples=16  # fewer\n", "s.txt");
  BOOST_REQUIRE(settings.size() == 2u);
  BOOST_TEST(settings[1].name == "fast");
  BOOST_TEST(settings[1].overrides[0].second == "16");

  // The defaults: quick first (the baseline), every tradeoff axis, the skipping pair.
  const auto d = default_settings();
  BOOST_TEST(d.front().name == "quick");
  BOOST_TEST(d.front().overrides.empty());
  for (const char* n : {"samples-32", "samples-64", "samples-128", "width-64", "width-128", "width-256",
                        "gemm-tuned", "gemm-clblast", "gemm-kernels", "skip-on", "skip-off"}) {
    bool found = false;
    for (const Setting& x : d) found = found || x.name == n;
    BOOST_TEST(found, n);
  }
  BOOST_TEST(unknown_keys(parse_setting("a:samples=64,width=128")).empty());
  const auto unknown = unknown_keys(parse_setting("a:samples=64,wings=2"));
  BOOST_REQUIRE(unknown.size() == 1u);
  BOOST_TEST(unknown[0] == "wings");
}

BOOST_AUTO_TEST_CASE(settings_errors_name_the_input) {
  BOOST_TEST(error_of([] { parse_setting(":samples=64"); }).find("no name") != std::string::npos);
  BOOST_TEST(error_of([] { parse_setting("a b:samples=64"); }).find("'a b'") != std::string::npos);
  BOOST_TEST(error_of([] { parse_setting("a/b"); }).find("'a/b'") != std::string::npos);
  BOOST_TEST(error_of([] { parse_setting("x:samples"); }).find("'samples' is not KEY=VALUE") != std::string::npos);
  BOOST_TEST(error_of([] { parse_setting("x:samples="); }).find("not KEY=VALUE") != std::string::npos);
  BOOST_TEST(error_of([] { parse_setting("x:gemm=blas"); }).find("'blas'") != std::string::npos);
  BOOST_TEST(error_of([] { parse_settings_text("a\nb:c\n", "f.txt"); }).find("f.txt:2") != std::string::npos);
  BOOST_TEST(error_of([] { parse_settings_text("# none\n", "f.txt"); }).find("no settings") != std::string::npos);
  BOOST_TEST(error_of([] { check_unique_names({parse_setting("a"), parse_setting("b"), parse_setting("a:width=8")}); })
                 .find("'a' is given twice") != std::string::npos);
}

BOOST_AUTO_TEST_CASE(budget_and_evaluation_points) {
  BOOST_TEST(parse_budget("1").scale == 1.0);
  BOOST_TEST(parse_budget("0.25").scale == 0.25);
  BOOST_TEST(parse_budget("0.25").seconds == 0.0);
  BOOST_TEST(parse_budget("300s").seconds == 300.0);
  for (const char* bad : {"0", "-1", "abc", "s", "2x", "", "nan", "0s"})
    BOOST_TEST(error_of([&] { parse_budget(bad); }).find("--budget") != std::string::npos, bad);

  BOOST_TEST(segment_ends(500, 2000, 4) == (std::vector<long>{500, 1000, 1500, 2000, 2500}));
  BOOST_TEST(segment_ends(0, 100, 3) == (std::vector<long>{33, 67, 100}));
  BOOST_TEST(segment_ends(10, 0, 2) == (std::vector<long>{5, 10}));
  BOOST_TEST(segment_ends(3, 2, 4) == (std::vector<long>{3, 4, 5}));  // no repeated step
  BOOST_TEST(spread_indices(24, 4) == (std::vector<int>{0, 8, 15, 23}));
  BOOST_TEST(spread_indices(3, 5) == (std::vector<int>{0, 1, 2}));
  BOOST_TEST(spread_indices(10, 1) == (std::vector<int>{0}));
}

BOOST_AUTO_TEST_CASE(speedup_at_equal_psnr) {
  // The baseline climbs 1 dB/s, the other 2 dB/s: both cross 25 dB halfway through their
  // third evaluation interval, at 15 s and 7.5 s. Every number is exact in binary.
  Curve base{"base", "base", curve({{0, 10}, {10, 20}, {20, 30}})};
  Curve fast{"fast", "fast", curve({{0, 10}, {5, 20}, {10, 30}})};
  BOOST_TEST(*time_to_reach(base.points, 25) == 15.0);
  BOOST_TEST(*time_to_reach(fast.points, 25) == 7.5);
  BOOST_TEST(*speedup_at(base, fast, 25) == 2.0);
  BOOST_TEST(*speedup_at(fast, base, 25) == 0.5);
  BOOST_TEST(*speedup_at(base, base, 25) == 1.0);
  // Reached at an evaluation exactly; and by the first one.
  BOOST_TEST(*time_to_reach(base.points, 20) == 10.0);
  BOOST_TEST(*time_to_reach(base.points, 5) == 0.0);
  // The first crossing counts, not a later one after a dip.
  BOOST_TEST(*time_to_reach(curve({{0, 10}, {4, 22}, {8, 18}, {12, 26}}), 20) == 10.0 / 3.0,
             boost::test_tools::tolerance(1e-12));
  // n/a: the other never reaches the level, or neither does.
  Curve slow{"slow", "slow", curve({{0, 10}, {10, 18}, {20, 22}})};
  BOOST_TEST(!time_to_reach(slow.points, 25).has_value());
  BOOST_TEST(!speedup_at(base, slow, 25).has_value());
  BOOST_TEST(!speedup_at(slow, base, 25).has_value());
  BOOST_TEST(!speedup_at(base, fast, 31).has_value());
  BOOST_TEST(!time_to_reach({}, 0).has_value());
}

BOOST_AUTO_TEST_CASE(csv_and_plot) {
  Curve a{"quick", "quick", {{0, 0, 0, 11.5, 0.25, 0}, {1, 500, 12.3456, 20.25, 0.5, 10376.9}}};
  Curve b{"width-64", "quick", a.points};
  BOOST_TEST(csv_text({a, b}) ==
             "setting,run,segment,steps,train_seconds,psnr,ssim,rays_per_s\n"
             "quick,quick,0,0,0.000,11.5000,0.25000,0.0\n"
             "quick,quick,1,500,12.346,20.2500,0.50000,10376.9\n"
             "width-64,quick,0,0,0.000,11.5000,0.25000,0.0\n"
             "width-64,quick,1,500,12.346,20.2500,0.50000,10376.9\n");

  double step = 0;
  BOOST_TEST(nova::axis_ticks(0, 430, 6, &step) == (std::vector<double>{0, 100, 200, 300, 400}));
  BOOST_TEST(step == 100.0);
  BOOST_TEST(nova::axis_ticks(18.5, 29.2, 6, &step) == (std::vector<double>{20, 22, 24, 26, 28}));
  BOOST_TEST(nova::axis_tick_text(22, step) == "22");
  nova::axis_ticks(0.1, 0.9, 6, &step);
  BOOST_TEST(nova::axis_tick_text(0.4, step) == "0.4");

  // Two series: each colour is drawn (Tableau blue and orange, RGB), the axes are black,
  // and the PNG reads back at its size.
  const std::vector<Series> s = {{"quick = width-64", {{0, 11}, {100, 20}, {300, 26}}},
                                 {"samples-128", {{0, 11}, {250, 21}, {700, 27}}}};
  const Image8 img = plot(s, "test", 25.0, 800, 500);
  BOOST_REQUIRE(img.width == 800 && img.height == 500 && img.channels == 3);
  TempDir dir("tradeoff-plot");
  write_png((dir / "p.png").string(), img);
  const Image8 back = read_rgb((dir / "p.png").string());
  BOOST_REQUIRE(back.width == 800 && back.height == 500);
  const auto count = [&](int r, int g, int b) {
    long n = 0;
    for (int y = 0; y < back.height; ++y)
      for (int x = 0; x < back.width; ++x)
        n += back.at(x, y, 0) == r && back.at(x, y, 1) == g && back.at(x, y, 2) == b;
    return n;
  };
  BOOST_TEST(count(31, 119, 180) > 200);   // series 1: line, markers, legend
  BOOST_TEST(count(255, 127, 14) > 200);   // series 2
  BOOST_TEST(count(0, 0, 0) > 1000);       // frame, ticks, labels
  BOOST_TEST(count(44, 160, 44) == 0);     // no third series
  BOOST_TEST(plot({}, "empty").width == 1000);  // nothing to draw is no error
}

// The command on the tiny scene: two trainings (a third setting equals the first and is
// reported without training again, a fourth names an option nova train lacks and is skipped
// with a warning), 3 + 6 steps, two joint segments, two camera-0 views.
BOOST_AUTO_TEST_CASE(runs_on_the_tiny_scene) {
  if (!has_bench()) return;
  TempDir dir("tradeoff-run");
  const std::string out = (dir / "t").string();
  const Result r = bench_cli("--scene " + cached_tiny_scene().string() + " --out " + out + " --base " + kTinyBase +
                                 " --segments 2 --eval-views 2 --setting a --setting b:samples=16"
                                 " --setting c:samples=8 --setting d:no-such-key=1",
                             dir);
  BOOST_REQUIRE_MESSAGE(r.code == 0, r.err);
  BOOST_TEST(r.err.find("warning: skipping setting 'd': 'no-such-key' is not an option") != std::string::npos, r.err);
  for (const char* f : {"tradeoff.csv", "tradeoff.png", "summary.txt", "runs/a/config.ini", "runs/a/metrics.jsonl",
                        "runs/b/metrics.jsonl"})
    BOOST_TEST(fs::exists(fs::path(out) / f), f);
  BOOST_TEST(!fs::exists(fs::path(out) / "runs/c"));        // trained once, as a
  BOOST_TEST(!fs::exists(fs::path(out) / "runs/a.warmup"));
  BOOST_TEST(!fs::exists(fs::path(out) / "runs/a/checkpoint.bin"));
  const std::string csv = read_all(fs::path(out) / "tradeoff.csv");
  // Step 0, the end of pretraining, two joint segments: 4 rows per setting.
  for (const char* row : {"a,a,0,0,0.000,", "a,a,1,3,", "a,a,3,9,", "b,b,3,9,", "c,a,3,9,"})
    BOOST_TEST(csv.find(row) != std::string::npos, row << " not in " << csv);
  BOOST_TEST(std::count(csv.begin(), csv.end(), '\n') == 13);
  BOOST_TEST(r.out.find("speedup at equal PSNR") != std::string::npos, r.out);
  BOOST_TEST(r.out.find("(baseline)") != std::string::npos, r.out);
  const Image8 png = read_rgb((fs::path(out) / "tradeoff.png").string());
  BOOST_TEST(png.width == 1000);

  // A seconds budget larger than the schedule needs: the first slice trains to the end and
  // the run stops there (step 0, then step 9).
  const std::string out2 = (dir / "t2").string();
  const Result s = bench_cli("--scene " + cached_tiny_scene().string() + " --out " + out2 + " --base " + kTinyBase +
                                 " --segments 2 --eval-views 1 --budget 1000s --no-warmup --setting a",
                             dir);
  BOOST_REQUIRE_MESSAGE(s.code == 0, s.err);
  const std::string csv2 = read_all(fs::path(out2) / "tradeoff.csv");
  BOOST_TEST(std::count(csv2.begin(), csv2.end(), '\n') == 3, csv2);
  BOOST_TEST(csv2.find("a,a,1,9,") != std::string::npos, csv2);
}

BOOST_AUTO_TEST_CASE(bad_inputs_exit_2_and_leave_nothing) {
  if (!has_bench()) return;
  TempDir dir("tradeoff-bad");
  const std::string out = (dir / "t").string(), scene = cached_tiny_scene().string();
  const auto expect = [&](const std::string& args, const std::string& needle, long lines = 1) {
    const Result r = bench_cli(args, dir);
    BOOST_TEST(r.code == 2, args << " -> exit " << r.code << ": " << r.err);
    BOOST_TEST(r.err.find(needle) != std::string::npos, args << ": '" << needle << "' not in: " << r.err);
    BOOST_TEST(std::count(r.err.begin(), r.err.end(), '\n') == lines, lines << " line(s): " << r.err);
    BOOST_TEST(!fs::exists(out), args);
  };
  expect("--scene " + (dir / "nowhere").string() + " --out " + out + " --setting a", "nowhere");
  expect("--scene " + scene + " --out " + out + " --setting samples=64", "'samples=64'");
  expect("--scene " + scene + " --out " + out + " --setting x:samples", "'samples' is not KEY=VALUE");
  expect("--scene " + scene + " --out " + out + " --setting x:samples=abc", "setting 'x'");
  expect("--scene " + scene + " --out " + out + " --setting x:width=8,skip=5", "setting 'x'");
  expect("--scene " + scene + " --out " + out + " --setting a --setting a:width=8", "'a' is given twice");
  expect("--scene " + scene + " --out " + out + " --settings " + (dir / "none.txt").string(), "none.txt");
  expect("--scene " + scene + " --out " + out + " --budget fast", "--budget 'fast'");
  expect("--scene " + scene + " --out " + out + " --setting d:no-such-key=1", "no setting left", 2);  // + the warning
  expect("--scene " + scene + " --out " + out + " --base wings=2", "'wings'");
  expect("--scene " + scene + " --out " + out + " --frobnicate 1", "--frobnicate");
  // An existing output folder is kept as it is.
  fs::create_directories(out);
  write_all(fs::path(out) / "keep.txt", "x");
  const Result r = bench_cli("--scene " + scene + " --out " + out, dir);
  BOOST_TEST(r.code == 2);
  BOOST_TEST(r.err.find("already exists") != std::string::npos, r.err);
  BOOST_TEST(fs::exists(fs::path(out) / "keep.txt"));
  // --dry-run prints the plan and writes nothing.
  fs::remove_all(out);
  const Result d = bench_cli("--out " + out + " --dry-run", dir);
  BOOST_TEST(d.code == 0, d.err);
  BOOST_TEST(d.out.find("samples-128") != std::string::npos, d.out);
  BOOST_TEST(d.out.find("same configuration as quick") != std::string::npos, d.out);
  BOOST_TEST(!fs::exists(out));
}

BOOST_AUTO_TEST_SUITE_END()

}  // namespace nova::test

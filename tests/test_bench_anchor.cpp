// nova-bench step --anchor: the NOVA code's log read step by step, a wrong anchor folder or
// interpreter refused before any step, and the alternation itself with a stand-in run.sh (no
// anchor folder and no torch needed): the rounds, the ratios, its run's failures as errors.
#include <boost/test/unit_test.hpp>
#include <sstream>

#include "../bench/anchor_run.hpp"
#include "scene_test_util.hpp"

namespace nova::test {
namespace {

bool has_bench() { return built("nova-bench"); }

// A folder that passes for the anchor: `run_sh` as its run.sh, an empty data/Balloon1, and an
// interpreter that imports everything (a script that exits 0).
struct StandIn {
  TempDir dir{"bench-anchor"};
  fs::path anchor = dir / "anchor", python = dir / "python";
  explicit StandIn(const std::string& run_sh) {
    fs::create_directories(anchor / "data" / "Balloon1");
    write_all(anchor / "run.sh", run_sh);
    write_all(python, "#!/bin/sh\nexit 0\n");
    fs::permissions(python, fs::perms::owner_all);
  }
  // One round of quick steps on the tiny scene beside the stand-in.
  CommandResult run(const std::string& extra = "", const std::string& env = "") const {
    return run_built("nova-bench",
                     "step --anchor " + anchor.string() + " --anchor-python " + python.string() + " --scene " +
                         cached_tiny_scene().string() +
                         " --factor 1 --presets quick --objects 1 --warmup 1 --steps 1 --profile-steps 0 " + extra,
                     dir, env);
  }
};

// Writes the log lines the patched NOVA code writes, from the variables run.sh is given.
const std::string kLoggingRunSh = R"(mkdir -p "$1"
log="$1/nova_ref.log"
echo "nova_ref: pretrain $NOVA_PRE_STEPS + joint $NOVA_JOINT_STEPS steps, log $log" > "$log"
for i in $(seq 0 $((NOVA_PRE_STEPS - 1))); do
  echo "BENCH phase=pretrain i=$i wall=1.5000 cpu=2.9 nv=0 stamp=0.0 loss=0.1" >> "$log"
done
for i in $(seq 0 $((NOVA_JOINT_STEPS - 1))); do
  echo "BENCH phase=joint i=$i wall=$((4 + i % 2)).0000 cpu=7.0 nv=$(( i % 3 == 0 && i > NOVA_NV_START )) stamp=0.0 loss=0.2" >> "$log"
done
echo "BENCH_END torch=stand-in cuda=None threads=$NOVA_THREADS device=cpu skip=$NOVA_SUMMARY_SKIP" >> "$log"
)";

}  // namespace

BOOST_AUTO_TEST_SUITE(bench_anchor)

BOOST_AUTO_TEST_CASE(log_steps_from_the_skipped_ones_on) {
  std::istringstream log(
      "nova_ref: pretrain 3 + joint 5 steps, log /tmp/x/nova_ref.log\n"
      "BENCH phase=pretrain i=0 wall=12.5000 cpu=20.1 nv=0 stamp=1.0 loss=0.30000\n"
      "[TRAIN] Iter: 0 Loss: 0.3 PSNR: 10.2\n"
      "BENCH phase=pretrain i=1 wall=8.2500 cpu=16.0 nv=0 stamp=2.0 loss=0.20000\n"
      "BENCH phase=pretrain i=2 wall=8.7500 cpu=16.5 nv=0 stamp=3.0 loss=0.10000\n"
      "BENCH phase=joint i=0 wall=30.0000 cpu=55.0 nv=1 stamp=4.0 loss=0.50000\n"
      "BENCH phase=joint i=1 wall=15.0000 cpu=29.0 nv=0 stamp=5.0 loss=0.40000\n"
      "BENCH phase=joint i=2 wall=14.0000 cpu=27.0 nv=0 stamp=6.0 loss=0.40000\n"
      "BENCH phase=joint i=3 wall=20.0000 cpu=39.0 nv=1 stamp=7.0 loss=0.40000\n"
      "BENCH phase=joint i=4 wall=1Traceback (most recent call last):\n"
      "BENCH_END torch=1.13.0a0 cuda=None numpy=1.24.2 python=3.11.2 device=cpu threads=2 train_seconds=120.0\n");
  const bench::AnchorSteps s = bench::parse_anchor_log(log, 1);
  BOOST_TEST(s.pretrain == (std::vector<double>{8.25, 8.75}), boost::test_tools::per_element());
  BOOST_TEST(s.joint == (std::vector<double>{15.0, 14.0, 20.0}), boost::test_tools::per_element());
  BOOST_TEST(s.joint_novel_view == 1);
  BOOST_TEST(s.logged_pretrain == 3);
  BOOST_TEST(s.logged_joint == 4);  // the broken line is no step
  BOOST_TEST(s.end.at("torch") == "1.13.0a0");
  BOOST_TEST(s.end.at("threads") == "2");

  std::istringstream unfinished("BENCH phase=pretrain i=0 wall=9.0 cpu=1 nv=0 stamp=0 loss=1\n");
  const bench::AnchorSteps u = bench::parse_anchor_log(unfinished, 0);
  BOOST_TEST(u.pretrain.size() == 1u);
  BOOST_TEST(u.joint.empty());
  BOOST_TEST(u.end.empty());
}

BOOST_AUTO_TEST_CASE(a_wrong_anchor_is_refused_before_any_step, *boost::unit_test::precondition([](auto) { return has_bench(); })) {
  TempDir dir("bench-anchor-bad");
  const fs::path missing = dir / "nova_ref", empty = dir / "empty";
  fs::create_directories(empty);
  for (const auto& [args, names] : std::vector<std::pair<std::string, std::string>>{
           {"--anchor " + missing.string(), missing.string() + "' is no folder"},
           {"--anchor " + empty.string(), empty.string() + "' has no run.sh"},
           {"--anchor " + missing.string() + " --rounds 0", "--rounds"},
           {"--anchor " + missing.string() + " --run " + missing.string(), missing.string() + "' is no folder"}}) {
    const CommandResult r = run_built("nova-bench", "step " + args, dir);
    BOOST_TEST(r.code == 2, args);
    BOOST_TEST(r.err.find(names) != std::string::npos, args << ": " << r.err);
    BOOST_TEST(r.out.find("s/step") == std::string::npos, args);  // no step ran
  }
  const StandIn s("exit 0\n");
  const CommandResult r = run_built("nova-bench", "step --anchor " + s.anchor.string() + " --anchor-python " +
                                                      (dir / "no-python").string(), dir);
  BOOST_TEST(r.code == 2);
  BOOST_TEST(r.err.find("--anchor-python: " + (dir / "no-python").string() + " cannot run the NOVA code") !=
                 std::string::npos, r.err);
}

BOOST_AUTO_TEST_CASE(rounds_alternate_with_the_nova_code, *boost::unit_test::precondition([](auto) { return has_bench(); })) {
  const StandIn s(kLoggingRunSh);
  const fs::path csv = s.dir / "anchor.csv";
  const CommandResult r = s.run("--rounds 2 --out " + csv.string());
  BOOST_TEST_REQUIRE(r.code == 0, r.err << r.out);
  // nova's steps (1 warm-up + 1 timed), so the NOVA code runs 2 of each phase, leaves out 1,
  // and augments joint step 0 as nova's reference preset does
  BOOST_TEST(r.out.find("pretraining 2 + joint 2 steps a round, the first 1 of each left out") != std::string::npos, r.out);
  BOOST_TEST(r.out.find("i > -1") != std::string::npos, r.out);
  BOOST_TEST(r.out.find("NOVA code, round 2: pretraining 1.500 s/step (1 timed), joint 5.000 s/step (1 timed, 0 "
                        "novel-view); torch stand-in") != std::string::npos, r.out);
  BOOST_TEST(r.out.find("each side's best round") != std::string::npos, r.out);
  std::istringstream lines(read_all(csv));
  std::string line;
  std::getline(lines, line);
  BOOST_TEST(line == "round,phase,nova_seconds_per_step,nova_code_seconds_per_step,nova_code_over_nova");
  std::vector<std::string> rows;
  while (std::getline(lines, line)) rows.push_back(line);
  BOOST_REQUIRE(rows.size() == 4u);
  BOOST_TEST(rows[0].rfind("1,pretrain,", 0) == 0u);
  BOOST_TEST(rows[3].rfind("2,joint,", 0) == 0u);
  for (const std::string& row : rows) {
    std::vector<double> v;
    std::istringstream cells(row);
    for (std::string cell; std::getline(cells, cell, ',');) v.push_back(std::atof(cell.c_str()));
    BOOST_REQUIRE(v.size() == 5u);
    BOOST_TEST(v[2] > 0.0);
    BOOST_TEST(v[3] == (row.find(",joint,") != std::string::npos ? 5.0 : 1.5));
    BOOST_TEST(v[4] == v[3] / v[2], boost::test_tools::tolerance(1e-3));
  }
}

// With --run, a phase a trained run is in continues that run (its grids skip empty space), the
// other phase stays the dense step; runs that do not fit the NOVA code's scene are refused.
BOOST_AUTO_TEST_CASE(trained_runs_stand_for_their_phases, *boost::unit_test::precondition([](auto) { return built("nova") && has_bench(); })) {
  const StandIn s(kLoggingRunSh);
  const fs::path pre = s.dir / "pre", joint = s.dir / "joint";
  const std::string scene = cached_tiny_scene().string();
  const CommandResult a = run_built("nova", "train --scene " + scene + " --out " + pre.string() +
                                                " --pretrain-steps 4 --steps 0 --occupancy-warmup 2 --occupancy-every 2", s.dir);
  BOOST_TEST_REQUIRE(a.code == 0, a.err);
  const CommandResult b = run_built("nova", "train --scene " + scene + " --out " + joint.string() +
                                                " --pretrain-steps 4 --steps 6 --occupancy-warmup 2 --occupancy-every 2", s.dir);
  BOOST_TEST_REQUIRE(b.code == 0, b.err);
  const std::string checkpoint = read_all(joint / "checkpoint.bin");
  const std::string base = "step --anchor " + s.anchor.string() + " --anchor-python " + s.python.string() + " --scene " +
                           scene + " --factor 1 --presets quick --warmup 1 --steps 1 --rounds 1 ";

  const CommandResult both = run_built("nova-bench", base + "--profile-steps 1 --objects 2 --run " + pre.string() + "," + joint.string(), s.dir);
  BOOST_TEST_REQUIRE(both.code == 0, both.err << both.out);
  BOOST_TEST(both.out.find("nova's pretraining steps: continuing run " + pre.string() + " from step 4") != std::string::npos,
             both.out);
  BOOST_TEST(both.out.find("nova's joint steps: continuing run " + joint.string() + " from step 10") != std::string::npos,
             both.out);
  BOOST_TEST(both.out.find("each side's best round") != std::string::npos, both.out);
  BOOST_TEST(both.out.find("quick joint K=2, continuing " + joint.string() + " (1 profiled steps)") != std::string::npos,
             both.out);  // the profile is of the run's steps too
  BOOST_TEST(read_all(joint / "checkpoint.bin") == checkpoint);  // continued in a copy

  const CommandResult one = run_built("nova-bench", base + "--profile-steps 0 --objects 2 --run " + joint.string(), s.dir);
  BOOST_TEST_REQUIRE(one.code == 0, one.err << one.out);
  BOOST_TEST(one.out.find("nova's pretraining steps: the dense step") != std::string::npos, one.out);

  for (const auto& [args, names] : std::vector<std::pair<std::string, std::string>>{
           {"--profile-steps 0 --objects 1 --run " + joint.string(), "with 2 objects; the NOVA code steps on"},
           {"--profile-steps 0 --objects 2 --run " + joint.string() + "," + joint.string(), "both runs are in the joint phase"}}) {
    const CommandResult r = run_built("nova-bench", base + args, s.dir);
    BOOST_TEST(r.code == 2, args);
    BOOST_TEST(r.err.find(names) != std::string::npos, args << ": " << r.err);
    BOOST_TEST(r.out.find("s/step") == std::string::npos, args);
  }
}

BOOST_AUTO_TEST_CASE(a_failed_or_late_run_is_an_error, *boost::unit_test::precondition([](auto) { return has_bench(); })) {
  const CommandResult failed = StandIn("echo 'ModuleNotFoundError: boom'\nexit 3\n").run();
  BOOST_TEST(failed.code == 1);
  BOOST_TEST(failed.err.find("failed with exit status 3") != std::string::npos, failed.err);
  BOOST_TEST(failed.err.find("ModuleNotFoundError: boom") != std::string::npos, failed.err);

  const CommandResult late = StandIn("timeout \"$NOVA_TIMEOUT\" sleep 30\n").run("", "NOVA_TIMEOUT=1");
  BOOST_TEST(late.code == 1);
  BOOST_TEST(late.err.find("timed out: NOVA_TIMEOUT=1 s") != std::string::npos, late.err);

  const CommandResult silent = StandIn("mkdir -p \"$1\"; echo 'no steps' > \"$1/nova_ref.log\"\n").run();
  BOOST_TEST(silent.code == 1);
  BOOST_TEST(silent.err.find("has 0 pretraining and 0 joint steps") != std::string::npos, silent.err);
}

BOOST_AUTO_TEST_SUITE_END()

}  // namespace nova::test

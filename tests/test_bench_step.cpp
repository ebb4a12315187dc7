// nova-bench step on the tiny synthetic scene: one row per phase and object count with a
// positive step time and device memory in its CSV, a per-op table, and bad inputs refused
// (exit code 2, a line naming the input, no CSV left behind). Each row counts the commands
// a step enqueues. Where /usr/bin/python3 has torch,
// each row also has PyTorch's step of the same MLPs.
#include <boost/test/unit_test.hpp>
#include <cstdlib>
#include <sstream>
#include <sys/wait.h>

#include "scene_test_util.hpp"

namespace nova::test {
namespace {

CommandResult run_bench_step(const std::string& args, const TempDir& dir) {
  return run_built("nova-bench", "step " + args, dir);
}

bool has_bench() { return built("nova-bench"); }

}  // namespace

BOOST_AUTO_TEST_SUITE(bench_step)

BOOST_AUTO_TEST_CASE(rows_for_each_phase_and_object_count, *boost::unit_test::precondition([](auto) { return has_bench(); })) {
  TempDir dir("bench-step");
  const fs::path csv = dir / "step.csv";
  const CommandResult r = run_bench_step("--scene " + cached_tiny_scene().string() +
                                  " --presets quick --objects 1,2 --steps 1 --warmup 1 --profile-steps 1 --out " +
                                  csv.string(),
                              dir);
  BOOST_TEST_REQUIRE(r.code == 0, r.err);
  std::istringstream lines(read_all(csv));
  std::string line;
  std::getline(lines, line);
  BOOST_TEST(line.rfind("preset,phase,objects,", 0) == 0u);
  BOOST_TEST(line.find(",torch_mlps_seconds_per_step,kernels_per_step,clblast_calls_per_step,host_calls_per_step,"
                       "memory_commands_per_step") != std::string::npos);
  const bool torch = std::system("/usr/bin/python3 -c 'import torch' >/dev/null 2>&1") == 0;
  std::vector<std::string> rows;
  while (std::getline(lines, line)) rows.push_back(line);
  BOOST_REQUIRE(rows.size() == 3u);  // pretrain, joint K=1, joint K=2
  BOOST_TEST(rows[0].rfind("quick,pretrain,0,", 0) == 0u);
  BOOST_TEST(rows[1].rfind("quick,joint,1,", 0) == 0u);
  BOOST_TEST(rows[2].rfind("quick,joint,2,", 0) == 0u);
  for (const std::string& row : rows) {
    std::vector<double> v;
    std::istringstream cells(row);
    for (std::string cell; std::getline(cells, cell, ',');) v.push_back(std::atof(cell.c_str()));
    BOOST_REQUIRE(v.size() == 14u);     // the PyTorch cell is empty (0) without torch
    if (torch) BOOST_TEST(v[9] > 0.0);  // PyTorch's MLPs, alternating
    BOOST_TEST(v[10] + v[11] + v[12] >= 10.0);  // kernels, CLBlast and host calls: a step is many
    BOOST_TEST(v[13] >= 1.0);                   // memory commands: at least the batch's upload
    BOOST_TEST(v[5] > 0.0);  // seconds per step
    BOOST_TEST(v[7] > 0.0);  // device MB
    BOOST_TEST(v[8] > 0.0);  // peak RSS MB
  }
  BOOST_TEST(r.out.find("hash_encoding (backward)") != std::string::npos);  // the per-op tables
}

BOOST_AUTO_TEST_CASE(bad_inputs_are_refused, *boost::unit_test::precondition([](auto) { return has_bench(); })) {
  TempDir dir("bench-step-bad");
  const fs::path csv = dir / "step.csv";
  const std::string scene = " --scene " + cached_tiny_scene().string();
  for (const auto& [args, names] : std::vector<std::pair<std::string, std::string>>{
           {scene + " --objects 9", "--objects"},
           {scene + " --presets fast", "fast"},
           {scene + " --steps 0", "--steps"},
           {" --scene " + (dir / "missing").string(), "missing"},
           {"", "--scene"}}) {
    const CommandResult r = run_bench_step(args + " --out " + csv.string(), dir);
    BOOST_TEST(r.code == 2, args);
    BOOST_TEST(r.err.find(names) != std::string::npos, args << ": " << r.err);
    BOOST_TEST(!fs::exists(csv), args);
  }
}

// --run continues a copy of a trained run: one row of the run's own phase and object count,
// and the run folder itself is left as it was.
BOOST_AUTO_TEST_CASE(continues_a_trained_run, *boost::unit_test::precondition([](auto) { return built("nova") && has_bench(); })) {
  TempDir dir("bench-step-run");
  const fs::path run = dir / "run", csv = dir / "step.csv";
  const CommandResult trained = run_built("nova", "train --scene " + cached_tiny_scene().string() + " --out " + run.string() +
                                               " --pretrain-steps 4 --steps 6 --occupancy-warmup 2 --occupancy-every 2", dir);
  BOOST_TEST_REQUIRE(trained.code == 0, trained.err);
  const std::string checkpoint = read_all(run / "checkpoint.bin");
  const CommandResult r = run_bench_step("--run " + run.string() + " --steps 1 --warmup 1 --profile-steps 1 --out " + csv.string(), dir);
  BOOST_TEST_REQUIRE(r.code == 0, r.err);
  BOOST_TEST(r.out.find("step 10, joint") != std::string::npos, r.out);
  std::istringstream lines(read_all(csv));
  std::string header, row, extra;
  std::getline(lines, header);
  std::getline(lines, row);
  BOOST_TEST(row.rfind("quick,joint,2,", 0) == 0u, row);  // the tiny scene's two objects
  BOOST_TEST(!std::getline(lines, extra));
  BOOST_TEST(r.out.find("hash_encoding (backward)") != std::string::npos);  // its per-op table
  BOOST_TEST(read_all(run / "checkpoint.bin") == checkpoint);
  const CommandResult missing = run_bench_step("--run " + (dir / "none").string(), dir);
  BOOST_TEST(missing.code == 2);
  BOOST_TEST(missing.err.find((dir / "none").string()) != std::string::npos, missing.err);
}

BOOST_AUTO_TEST_SUITE_END()

}  // namespace nova::test

// nova-bench devices on two PoCL devices of the test machine (POCL_DEVICES="pthread basic"; and
// the machine's GPUs where it has them): one row per device with the MLP's error against float64 within float32 rounding, a PSNR and its
// difference from the first device, and the four outputs; a device that fails (here: an MLP
// batch no device can hold) is a row naming the stage and the error, the run goes on and
// exits 1; bad options exit 2.
#include <boost/test/unit_test.hpp>
#include <cstdlib>
#include <map>
#include <sstream>
#include <sys/wait.h>

#include "scene_test_util.hpp"

namespace nova::test {
namespace {

CommandResult run_devices(const std::string& args, const TempDir& dir) {
  return run_built("nova-bench", "devices " + args, dir, "POCL_DEVICES='pthread basic'");
}

bool has_bench() { return built("nova-bench"); }

// Devices under the same PoCL set-up, by `nova devices` (a GPU machine adds its GPUs to the
// two PoCL devices).
size_t device_count(const TempDir& dir) {
  const CommandResult r = run_built("nova", "devices", dir, "POCL_DEVICES='pthread basic'");
  BOOST_TEST_REQUIRE(r.code == 0, r.err);
  std::istringstream in(r.out);
  size_t n = 0;
  for (std::string line; std::getline(in, line);)
    n += !line.empty() && std::isdigit(static_cast<unsigned char>(line[0])) && line.find(':') != std::string::npos;
  return n;
}

// The CSV's rows as column -> value.
std::vector<std::map<std::string, std::string>> csv_rows(const fs::path& p) {
  std::istringstream in(read_all(p));
  std::string line;
  std::getline(in, line);
  std::vector<std::string> header;
  std::istringstream h(line);
  for (std::string c; std::getline(h, c, ',');) header.push_back(c);
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    std::map<std::string, std::string> r;
    std::istringstream cells(line);
    size_t i = 0;
    for (std::string c; std::getline(cells, c, ',') && i < header.size(); ++i) r[header[i]] = c;
    rows.push_back(r);
  }
  return rows;
}

const std::string kSmall =
    " --batch 1024 --depth 2 --width 32 --repeats 1 --check-rows 16 --composite-rays 512 --pretrain-steps 10 --steps 10";

}  // namespace

BOOST_AUTO_TEST_SUITE(bench_devices)

BOOST_AUTO_TEST_CASE(two_pocl_devices_side_by_side, *boost::unit_test::precondition([](auto) { return has_bench(); })) {
  TempDir dir("bench-devices");
  const CommandResult r = run_devices("--scene " + cached_tiny_scene().string() + kSmall + " --out " + (dir / "out").string(), dir);
  BOOST_TEST_REQUIRE(r.code == 0, r.err << r.out);
  for (const char* f : {"devices.md", "devices.csv", "devices.json", "devices.png"}) BOOST_TEST(fs::exists(dir / "out" / f), f);
  const auto rows = csv_rows(dir / "out" / "devices.csv");
  BOOST_REQUIRE(rows.size() >= 2u);
  if (built("nova")) BOOST_TEST(rows.size() == device_count(dir));
  for (const auto& row : rows) {
    BOOST_TEST(row.at("status") == "ok");
    // Float32 GEMMs of 63..32-wide layers against float64: a few ulp of the largest value.
    BOOST_TEST(std::stod(row.at("mlp_out_err")) < 1e-5);
    BOOST_TEST(std::stod(row.at("mlp_grad_err")) < 1e-5);
    BOOST_TEST(std::stod(row.at("mlp_samples_s")) > 0.0);
    BOOST_TEST(std::stod(row.at("composite_samples_s")) > 0.0);
    BOOST_TEST(std::stod(row.at("psnr")) > 5.0);
    BOOST_TEST(std::stod(row.at("view_s")) > 0.0);
    BOOST_TEST(!row.at("psnr_diff").empty());
  }
  BOOST_TEST(rows[0].at("psnr_diff") == "0.000");
}

BOOST_AUTO_TEST_CASE(a_failing_device_is_a_row, *boost::unit_test::precondition([](auto) { return has_bench(); })) {
  TempDir dir("bench-devices-fail");
  // 2^27 rows of 63 inputs: more than any one buffer may hold (and than 32-bit indexing).
  const CommandResult r = run_devices("--devices 0:0 --scene " + cached_tiny_scene().string() + kSmall +
                                   " --batch 134217728 --out " + (dir / "out").string(),
                               dir);
  BOOST_TEST(r.code == 1, r.err);
  const auto rows = csv_rows(dir / "out" / "devices.csv");
  BOOST_REQUIRE(rows.size() == 1u);
  BOOST_TEST(rows[0].at("status").find("failed") == 0u, rows[0].at("status"));
  BOOST_TEST(rows[0].at("status").find("in mlp") != std::string::npos, rows[0].at("status"));
}

BOOST_AUTO_TEST_CASE(bad_options_are_refused, *boost::unit_test::precondition([](auto) { return has_bench(); })) {
  TempDir dir("bench-devices-bad");
  for (const std::string& args : {std::string("--batch 0"), std::string("--composite-rays 0"), std::string("--devices 7:7"),
                                 "--scene " + (dir / "missing").string()}) {
    const CommandResult r = run_devices(args + " --out " + (dir / "out").string(), dir);
    BOOST_TEST(r.code == 2, args << ": " << r.err);
    BOOST_TEST(!fs::exists(dir / "out"), args);
  }
}

BOOST_AUTO_TEST_SUITE_END()

}  // namespace nova::test

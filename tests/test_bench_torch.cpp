// nova-bench mlp beside PyTorch: where /usr/bin/python3 has torch, one row per batch and pass
// with both rates and their ratio; where it has none, or the interpreter named cannot run, or
// --torch off, one line saying why, and the benchmark still succeeds.
#include <boost/test/unit_test.hpp>
#include <cstdlib>
#include <regex>

#include "scene_test_util.hpp"

namespace nova::test {
namespace {

const std::string kSmall = "--batches 256 --repeats 1 --width 16 --depth 2 --layer 16 --fused-widths 16";

bool has_bench() { return built("nova-bench"); }

bool system_python_has_torch() {
  return std::system("/usr/bin/python3 -c 'import torch' >/dev/null 2>&1") == 0;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(bench_torch)

BOOST_AUTO_TEST_CASE(auto_compares_where_torch_is_installed, *boost::unit_test::precondition([](auto) { return has_bench(); })) {
  TempDir dir("bench-torch");
  const CommandResult r = run_built("nova-bench", "mlp " + kSmall + " --torch auto --torch-threads 1", dir);
  BOOST_TEST_REQUIRE(r.code == 0, r.err);
  if (system_python_has_torch()) {
    const std::regex row(R"(256 +(forward|training step) +nova +[0-9]+ samples/s +PyTorch +[0-9]+ samples/s +nova / PyTorch +[0-9.]+ +\[torch )");
    const auto rows = std::distance(std::sregex_iterator(r.out.begin(), r.out.end(), row), std::sregex_iterator());
    BOOST_TEST(rows == 2, r.out);
    BOOST_TEST(r.out.find("256,training step,") != std::string::npos);  // its CSV row
  } else {
    BOOST_TEST(r.out.find("PyTorch: not compared (/usr/bin/python3: unavailable: No module named 'torch')") !=
                   std::string::npos,
               r.out);
  }
}

BOOST_AUTO_TEST_CASE(an_interpreter_that_cannot_run_is_one_line, *boost::unit_test::precondition([](auto) { return has_bench(); })) {
  TempDir dir("bench-torch-missing");
  const CommandResult r = run_built("nova-bench", "mlp " + kSmall + " --torch " + (dir / "no-python").string(), dir);
  BOOST_TEST_REQUIRE(r.code == 0, r.err);
  BOOST_TEST(r.out.find("PyTorch: not compared (" + (dir / "no-python").string() +
                        ": unavailable: cannot execute the interpreter)") != std::string::npos,
             r.out);
  const CommandResult off = run_built("nova-bench", "mlp " + kSmall + " --torch off", dir);
  BOOST_TEST_REQUIRE(off.code == 0, off.err);
  BOOST_TEST(off.out.find("PyTorch: not compared (--torch off") != std::string::npos, off.out);
}

BOOST_AUTO_TEST_SUITE_END()

}  // namespace nova::test

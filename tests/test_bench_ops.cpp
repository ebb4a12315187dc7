// nova-bench ops on a few small entries of the op table: the table's columns, one row per
// entry the filter matches (each at its largest shape) and a total, the same rows in its CSV,
// and bad options refused (exit code 2, a line naming the option). Times are read, never
// compared with a speed.
#include <boost/test/unit_test.hpp>
#include <cstdlib>
#include <regex>
#include <sstream>

#include "op_table.hpp"
#include "scene_test_util.hpp"

namespace nova::test {
namespace {

bool has_bench() { return built("nova-bench"); }

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(bench_ops)

BOOST_AUTO_TEST_CASE(one_row_per_matched_entry, *boost::unit_test::precondition([](auto) { return has_bench(); })) {
  TempDir dir("bench-ops");
  const std::string filter = "^(mse|concat|rank_sum)$";
  std::vector<std::string> names;
  for (const OpEntry& e : op_table())
    if (std::regex_search(e.name, std::regex(filter))) names.push_back(e.name);
  BOOST_TEST_REQUIRE(names.size() == 3u);
  const fs::path csv = dir / "ops.csv";
  const CommandResult r = run_built("nova-bench", "ops --reps 1 --filter '" + filter + "' --csv " + csv.string(), dir);
  BOOST_TEST_REQUIRE(r.code == 0, r.err);

  const std::vector<std::string> out = lines_of(r.out);
  const auto header = std::find_if(out.begin(), out.end(), [](const std::string& l) { return l.rfind("entry", 0) == 0; });
  BOOST_TEST_REQUIRE((header != out.end()), r.out);
  for (const char* column : {"shape", "fwd ms", "fwd+bwd ms", "GFLOP/s"})
    BOOST_TEST(header->find(column) != std::string::npos, "no column '" << column << "' in: " << *header);
  for (const std::string& name : names) {
    const auto rows = std::count_if(out.begin(), out.end(), [&](const std::string& l) { return l.rfind(name + " ", 0) == 0; });
    BOOST_TEST(rows == 1, rows << " rows for entry " << name << " in:\n" << r.out);
  }
  BOOST_TEST(std::count_if(out.begin(), out.end(), [](const std::string& l) { return l.rfind("total ", 0) == 0; }) == 1);

  const std::vector<std::string> rows = lines_of(read_all(csv));
  BOOST_TEST_REQUIRE(rows.size() == names.size() + 2);  // header, one per entry, total
  BOOST_TEST(rows[0] == "entry,shape,forward_ms,forward_backward_ms,gflops_per_s");
  for (size_t i = 0; i < names.size(); ++i) {
    BOOST_TEST(rows[i + 1].rfind("\"" + names[i] + "\",", 0) == 0u, rows[i + 1]);
    // The forward time: the first field after the quoted shape.
    const std::string after_shape = rows[i + 1].substr(rows[i + 1].rfind("\",") + 2);
    BOOST_TEST(std::atof(after_shape.c_str()) >= 0.0, rows[i + 1]);
  }
  BOOST_TEST(rows.back().rfind("\"total\",", 0) == 0u, rows.back());
}

BOOST_AUTO_TEST_CASE(bad_options_are_refused, *boost::unit_test::precondition([](auto) { return has_bench(); })) {
  TempDir dir("bench-ops-bad");
  for (const auto& [args, names] : std::vector<std::pair<std::string, std::string>>{
           {"--filter '('", "--filter"}, {"--filter no_such_entry", "--filter"}, {"--scale most", "--scale"},
           {"--reps 0", "--reps"}}) {
    const CommandResult r = run_built("nova-bench", "ops " + args, dir);
    BOOST_TEST(r.code == 2, args << ": exit code " << r.code);
    BOOST_TEST(r.err.find(names) != std::string::npos, args << ": " << r.err);
  }
}

BOOST_AUTO_TEST_SUITE_END()

}  // namespace nova::test

// Portable kernels: no embedded kernel source may depend on an optional OpenCL
// feature without a fallback. fp64, fp16, subgroups and every cl_khr_/vendor extension are
// optional on OpenCL 1.2 devices (PoCL has no fp16 or subgroups), so such code is allowed
// only inside an `#if`/`#ifdef` on the extension's macro that has an `#else` branch. Local
// memory and barriers are out by DEVELOPERS.md (PoCL pitfalls), atomics are allowed only as
// such an extension (64-bit integer sums, exact in any order), and a fixed work-group size
// attribute would contradict the host, which queries it.
// The lint is checked on small sources first, so that it is known to fail when it should.
#include <boost/test/unit_test.hpp>

#include <regex>
#include <string>
#include <vector>

#include "nova/runtime/kernel_sources.hpp"

namespace {

struct Rule {
  std::regex pattern;
  const char* why;
  bool extension;  // allowed inside an extension guard that has a fallback
};

const std::vector<Rule>& rules() {
  static const std::vector<Rule> r = {
      {std::regex(R"(#\s*pragma\s+OPENCL\s+EXTENSION)"), "enables an optional extension", true},
      {std::regex(R"(\bcl_(khr|ext|nv|amd|intel|arm|qcom|img|apple|altera|xilinx)_\w+)"),
       "uses an optional extension", true},
      {std::regex(R"(\bdouble\d*\b)"), "fp64 is optional (cl_khr_fp64)", true},
      {std::regex(R"(\bhalf\d*\b)"), "fp16 arithmetic is optional (cl_khr_fp16)", true},
      {std::regex(R"(sub_group)"), "subgroups are optional (cl_khr_subgroups)", true},
      // Integer atomics sum exactly in any order (the hash grid's fixed-point backward); float
      // sums by atomics would not be bit-reproducible, but OpenCL C has no float atomic add.
      {std::regex(R"(\batom(ic)?_\w+)"),
       "atomics: only 64-bit integer ones, inside a cl_khr_int64_base_atomics guard (DEVELOPERS.md)", true},
      {std::regex(R"(\b(__local|local)\b|\bbarrier\s*\()"),
       "local memory and barriers are PoCL pitfalls (DEVELOPERS.md)", false},
      {std::regex(R"(reqd_work_group_size|work_group_size_hint)"),
       "fixes a work-group size that the host queries instead", false},
  };
  return r;
}

const std::regex kGuard(R"(^\s*#\s*(if|ifdef|ifndef)\b.*\bcl_(khr|ext|nv|amd|intel|arm|qcom|img|apple|altera|xilinx)_\w+)");
const std::regex kIf(R"(^\s*#\s*(if|ifdef|ifndef)\b)");
const std::regex kElse(R"(^\s*#\s*(else|elif)\b)");
const std::regex kEndif(R"(^\s*#\s*endif\b)");

// Problems of one kernel source, each "line N: text (why)".
std::vector<std::string> lint(const std::string& family, const std::string& source) {
  std::string text = std::regex_replace(source, std::regex(R"(/\*[\s\S]*?\*/)"), " ");
  text = std::regex_replace(text, std::regex(R"(//[^\n]*)"), "");
  struct Block {
    bool guard;
    bool has_else;
    int line;
  };
  std::vector<Block> open;
  std::vector<std::string> problems;
  const auto where = [&](int line) { return "kernels/" + family + ".cl line " + std::to_string(line); };
  int line_no = 0;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t end = std::min(text.find('\n', start), text.size());
    const std::string line = text.substr(start, end - start);
    start = end + 1;
    ++line_no;
    if (std::regex_search(line, kIf)) {
      open.push_back({std::regex_search(line, kGuard), false, line_no});
      continue;  // the guard's own condition names the extension
    }
    if (std::regex_search(line, kElse)) {
      if (!open.empty()) open.back().has_else = true;
      continue;
    }
    if (std::regex_search(line, kEndif)) {
      if (!open.empty()) {
        if (open.back().guard && !open.back().has_else)
          problems.push_back(where(open.back().line) +
                             ": extension guard without an #else fallback");
        open.pop_back();
      }
      continue;
    }
    bool guarded = false;
    for (const Block& b : open) guarded = guarded || b.guard;
    for (const Rule& r : rules())
      if (std::regex_search(line, r.pattern) && !(r.extension && guarded))
        problems.push_back(where(line_no) + ": '" + line + "' (" + r.why + ")");
  }
  return problems;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(kernel_portability)

BOOST_AUTO_TEST_CASE(lint_finds_what_it_should) {
  BOOST_TEST(lint("t", "__kernel void k(__global float* x) { x[0] = 1.0f; }").empty());
  BOOST_TEST(lint("t", "// double in a comment\n/* half */ __kernel void k() {}").empty());
  BOOST_TEST(lint("t", "__kernel void k(__global double* x) {}").size() == 1u);
  BOOST_TEST(lint("t", "#pragma OPENCL EXTENSION cl_khr_fp16 : enable\n").size() == 2u);
  BOOST_TEST(lint("t", "__kernel void k(__local float* s) { barrier(CLK_LOCAL_MEM_FENCE); }").size() == 1u);
  BOOST_TEST(lint("t", "__kernel void k(__global int* c) { atomic_add(c, 1); }").size() == 1u);
  BOOST_TEST(lint("t", "__attribute__((reqd_work_group_size(64, 1, 1))) __kernel void k() {}").size() == 1u);
  // A guarded use with a fallback passes; without the fallback it does not.
  const std::string guarded =
      "#ifdef cl_khr_fp64\n#pragma OPENCL EXTENSION cl_khr_fp64 : enable\ntypedef double acc_t;\n"
      "#else\ntypedef float acc_t;\n#endif\n";
  BOOST_TEST(lint("t", guarded).empty());
  const std::string no_fallback =
      "#ifdef cl_khr_fp64\n#pragma OPENCL EXTENSION cl_khr_fp64 : enable\ntypedef double acc_t;\n#endif\n";
  BOOST_TEST(lint("t", no_fallback).size() == 1u);
  // Atomics likewise: unguarded (above) refused, guarded with a fallback allowed.
  BOOST_TEST(lint("t", "#ifdef cl_khr_int64_base_atomics\n__kernel void k(__global long* c) { atom_add(c, 1); }\n"
                       "#else\n#endif\n").empty());
}

BOOST_AUTO_TEST_CASE(every_embedded_kernel_is_portable) {
  size_t families = 0;
  for (const nova::KernelSource& k : nova::kernel_sources()) {
    ++families;
    for (const std::string& p : lint(std::string(k.family), std::string(k.source)))
      BOOST_ERROR(p);
  }
  BOOST_TEST(families >= 8u);
}

BOOST_AUTO_TEST_SUITE_END()

// Every entry of the op table (op_table.hpp) at every shape through the one harness
// (op_harness.hpp): forward against the float64 reference, gradients against their float64
// derivative and central differences, on executors that check every op against writes outside
// its tensors. Then the coverage: every op class the library defines has an entry, and every
// kernel of every embedded family ran at a size that leaves a partial work-group (the table's
// odd shapes, and the kernels outside ops in op_table_kernels.cpp) - no exemptions. Timing
// the table is `nova-bench ops` (bench/bench_ops.cpp).
//
// Shapes and tolerances are stated with each entry. Odd sizes: 1009 rows (a prime, more than
// any work-group nova chooses, so several groups and a partial last one on every device), odd
// widths and part counts, and 1-row cases. A kernel launch covers its kernel when, in every
// dimension, the problem size leaves a partial work-group (or the group is 1 wide there); on
// a device whose work-groups are all 1 wide, an odd size.
#include <boost/test/data/monomorphic.hpp>
#include <boost/test/data/test_case.hpp>
#include <boost/test/unit_test.hpp>

#include <algorithm>
#include <map>
#include <memory>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "harness.hpp"
#include "nova/runtime/error.hpp"
#include "nova/graph/executor.hpp"
#include "nova/runtime/kernel_sources.hpp"
#include "op_harness.hpp"
#include "op_table.hpp"

using namespace nova;
using namespace nova::test;
namespace utf = boost::unit_test;
namespace bdata = boost::unit_test::data;

namespace {

bool ragged(const LaunchRecord& r) {
  bool any_wide = false;
  for (size_t d = 0; d < r.dims; ++d) {
    if (r.local[d] > 1 && r.size[d] % r.local[d] == 0) return false;
    any_wide = any_wide || r.local[d] > 1;
  }
  return any_wide || r.size[0] % 2 == 1;
}

struct KernelName {
  std::string name;
  std::string extension;  // the `#ifdef cl_khr_...` it is defined under, or empty
};

// Kernel names of one embedded source: `__kernel void NAME(` with comments removed, each with
// the extension whose `#ifdef` (up to its #else or #endif) holds it.
std::vector<KernelName> kernel_names(std::string_view source) {
  std::string text(source);
  text = std::regex_replace(text, std::regex(R"(/\*[\s\S]*?\*/)"), " ");
  text = std::regex_replace(text, std::regex(R"(//[^\n]*)"), " ");
  std::vector<KernelName> names;
  const std::regex kernel(R"((?:__kernel|\bkernel)\s+void\s+(\w+)\s*\()");
  const std::regex ifdef(R"(^\s*#\s*ifdef\s+(cl_\w+))"), close(R"(^\s*#\s*(else|endif|elif))");
  std::string extension;
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    std::smatch m;
    if (std::regex_search(line, m, ifdef)) extension = m[1];
    else if (std::regex_search(line, close)) extension.clear();
    for (std::sregex_iterator it(line.begin(), line.end(), kernel), end; it != end; ++it)
      names.push_back({(*it)[1], extension});
  }
  return names;
}

bool device_has(const std::string& extension) {
  if (extension.empty()) return true;
  if (extension == "cl_khr_int64_base_atomics") return runtime().info().int64_atomics;
  return false;
}

// Writes `count` floats of its input's first row (a fill pattern) from the start of its
// output: count > the output's size is an out-of-bounds kernel.
class OverrunOp final : public Op {
 public:
  explicit OverrunOp(unsigned count) : count_(count) {}
  std::string type() const override { return "overrun"; }
  void forward(ExecContext& ctx) override {
    ctx.launch("packing", "fill_rows").arg(ctx.out(0)).arg(ctx.in(0)).arg(count_).arg(3u).run(count_);
  }
  void backward(ExecContext&) override {}

 private:
  unsigned count_;
};

// Where StrayWriteOp writes its one float: just before or just past its output (forward), its
// parameter input (forward) or that parameter's gradient (backward); Nowhere: no stray write.
enum class Stray { Nowhere, BeforeOutput, PastOutput, BeforeParameter, PastParameter, BeforeGradient, PastGradient };

// Writes one float just outside one of its buffers, as a kernel that under- or over-runs
// would: found through the sub-buffer's parent arena and offset, written in queue order.
class StrayWriteOp final : public Op {
 public:
  explicit StrayWriteOp(Stray where) : where_(where) {}
  std::string type() const override { return "stray"; }
  void forward(ExecContext& ctx) override {
    if (where_ == Stray::BeforeOutput || where_ == Stray::PastOutput) write_beside(ctx, ctx.out(0), where_ == Stray::PastOutput);
    if (where_ == Stray::BeforeParameter || where_ == Stray::PastParameter)
      write_beside(ctx, ctx.in(0), where_ == Stray::PastParameter);
  }
  void backward(ExecContext& ctx) override {
    if (where_ == Stray::BeforeGradient || where_ == Stray::PastGradient)
      write_beside(ctx, ctx.grad_in(0), where_ == Stray::PastGradient);
  }

 private:
  static void write_beside(ExecContext& ctx, cl_mem buffer, bool past) {
    cl_mem parent = nullptr;
    size_t offset = 0, bytes = 0;
    clGetMemObjectInfo(buffer, CL_MEM_ASSOCIATED_MEMOBJECT, sizeof(parent), &parent, nullptr);
    clGetMemObjectInfo(buffer, CL_MEM_OFFSET, sizeof(offset), &offset, nullptr);
    clGetMemObjectInfo(buffer, CL_MEM_SIZE, sizeof(bytes), &bytes, nullptr);
    BOOST_REQUIRE(parent != nullptr && offset >= sizeof(float));
    const float one = 1.0f;
    ctx.rt.upload(parent, &one, sizeof(one), past ? offset + bytes : offset - sizeof(float));
  }
  Stray where_;
};

}  // namespace

BOOST_FIXTURE_TEST_SUITE(op_table, RecordLaunches)

BOOST_DATA_TEST_CASE(entries, bdata::xrange(nova::test::op_table().size()), index) {
  const OpEntry& e = nova::test::op_table().at(index);
  for (const OpShape& s : e.shapes)
    BOOST_TEST_CONTEXT(e.name << " at " << s.label) { check_entry(e, s); }
}

// Every concrete op class of the library is built by some entry: a new op without an entry
// fails here.
BOOST_AUTO_TEST_CASE(every_op_class_has_an_entry) {
  const std::set<std::string> library = library_op_classes();
  BOOST_TEST(library.size() >= 25u, "only " << library.size() << " op classes parsed from host/");
  BOOST_TEST(library.count("LinearOp") == 1u);
  std::map<std::string, std::string> entry_of;
  for (const OpEntry& e : nova::test::op_table())
    for (const OpShape& s : e.shapes)
      for (const std::string& c : op_classes_built(e, s)) entry_of.emplace(c, e.name);
  for (const std::string& c : library)
    BOOST_TEST(entry_of.count(c) == 1u, "op class " << c << " has no entry in the op table (tests/op_table_*.cpp)");
  for (const auto& [c, name] : entry_of) BOOST_TEST_MESSAGE(c << ": " << name);
}

// A check of its own (op_table_checks.cpp) belongs to an entry of that name that has no
// float64 reference of the generic kind, so none is left behind by a renamed entry.
BOOST_AUTO_TEST_CASE(own_checks_name_entries_without_a_reference) {
  for (const auto& [name, check] : own_checks()) {
    const auto& t = nova::test::op_table();
    const auto e = std::find_if(t.begin(), t.end(), [&](const OpEntry& x) { return x.name == name; });
    BOOST_TEST_REQUIRE((e != t.end()), "own check '" << name << "' names no entry of the op table");
    BOOST_TEST(!e->reference, "entry '" << name << "' has a reference and a check of its own");
  }
}

// The guards catch a kernel that writes one float past its output (fill_rows with a count one
// larger than the tensor), and the same launch within bounds passes.
BOOST_AUTO_TEST_CASE(guards_catch_an_out_of_bounds_kernel) {
  for (unsigned count : {15u, 16u}) {
    Graph g;
    Tensor fill = g.input("fill", Shape{1, 3});
    Tensor y = g.activation("y", Shape{5, 3});
    g.add(std::make_unique<OverrunOp>(count), {fill}, {y});
    g.keep(y);
    Executor ex(runtime(), g, guarded_options());
    ex.set(fill, {1, 2, 3});
    if (count == 15) {
      ex.forward();
      BOOST_TEST(ex.get(y).back() == 3.0f);
      continue;
    }
    try {
      ex.forward();
      BOOST_ERROR("a write one float past tensor 'y' went unnoticed");
    } catch (const Error& err) {
      const std::string what = err.what();
      BOOST_TEST(what.find("op 'overrun'") != std::string::npos, what);
      BOOST_TEST(what.find("past the end of tensor 'y'") != std::string::npos, what);
    }
  }
}

// The guards sit before every tensor as well as past it, and around parameters and their
// gradients too: one float written just before an output, or beside a parameter or its
// gradient, is caught with the op and the tensor named; without a stray write the guarded run
// passes and a parameter gradient no op writes reads 0.
BOOST_AUTO_TEST_CASE(guards_catch_writes_before_a_tensor_and_beside_parameters) {
  const std::vector<std::pair<Stray, std::string>> cases = {
      {Stray::BeforeOutput, "before the start of tensor 'y'"},
      {Stray::PastOutput, "past the end of tensor 'y'"},
      {Stray::BeforeParameter, "before the start of parameter 'w'"},
      {Stray::PastParameter, "past the end of parameter 'w'"},
      {Stray::BeforeGradient, "before the start of the gradient of parameter 'w'"},
      {Stray::PastGradient, "past the end of the gradient of parameter 'w'"},
      {Stray::Nowhere, ""}};
  for (const auto& [where, named] : cases) {
    Graph g;
    Tensor w = g.parameter("w", Shape{3, 5}, Init::uniform(0.5f));
    Tensor y = g.activation("y", Shape{1});
    g.add(std::make_unique<StrayWriteOp>(where), {w}, {y});
    g.set_loss(y);
    Executor ex(runtime(), g, guarded_options());
    const std::vector<float> weights = random_floats(15, -1, 1, 3);
    ex.set(w, weights);
    try {
      ex.forward();
      ex.backward();
      BOOST_TEST(named.empty(), "a write " << named << " went unnoticed");
      BOOST_TEST(ex.get(w) == weights);
      BOOST_TEST(ex.get_grad(w) == std::vector<float>(15, 0.0f));
    } catch (const Error& err) {
      const std::string what = err.what();
      BOOST_TEST(!named.empty(), what);
      BOOST_TEST(what.find("op 'stray'") != std::string::npos, what);
      BOOST_TEST(what.find(named) != std::string::npos, what);
    }
  }
}

BOOST_AUTO_TEST_CASE(every_kernel_ran_at_an_odd_size,
                     *utf::depends_on("op_table/entries") * utf::depends_on("op_table/optimiser") *
                         utf::depends_on("op_table/own_gemm_kernels") *
                         utf::depends_on("op_table/termination_kernels")) {
  std::map<std::pair<std::string, std::string>, std::vector<LaunchRecord>> by_kernel;
  for (const LaunchRecord& r : runtime().launches()) by_kernel[{r.family, r.name}].push_back(r);
  size_t kernels = 0;
  for (const KernelSource& src : kernel_sources()) {
    const std::string family(src.family);
    if (src.family == kKernelPrelude) continue;  // helpers only, compiled into every family
    const auto names = kernel_names(src.source);
    BOOST_TEST(!names.empty(), "no kernel found in kernels/" << family << ".cl");
    for (const KernelName& k : names) {
      if (!device_has(k.extension)) {
        BOOST_TEST_MESSAGE(family << "/" << k.name << ": the device has no " << k.extension);
        continue;
      }
      ++kernels;
      const auto it = by_kernel.find({family, k.name});
      const bool launched = it != by_kernel.end();
      const bool odd = launched && std::any_of(it->second.begin(), it->second.end(), ragged);
      BOOST_TEST(odd, "kernel " << k.name << " of kernels/" << family << ".cl was "
                                << (launched ? "launched only at sizes that fill whole work-groups"
                                             : "never launched")
                                << " by the op table: add an entry or a shape (tests/op_table_*.cpp)");
    }
  }
  BOOST_TEST(kernels >= 40u, "only " << kernels << " kernels parsed from the embedded sources");
}

BOOST_AUTO_TEST_SUITE_END()

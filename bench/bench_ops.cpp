// nova-bench ops: the op table (tests/op_table.hpp) timed. Per entry and shape: ms of one
// forward, ms of one forward + backward, and GFLOP/s (the entry's FLOP count of a forward +
// backward over that time), on executors without guards, median of --reps after a warm-up;
// then the total. Speeds are measured here and never asserted in tests.
#include <algorithm>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <regex>
#include <sstream>

#include "bench.hpp"
#include "nova/runtime/error.hpp"
#include "nova/graph/executor.hpp"
#include "nova/runtime/runtime.hpp"
#include "op_table.hpp"
#include "options.hpp"

namespace nova::bench {
namespace {

using test::OpEntry;
using test::OpShape;

struct Row {
  std::string entry, shape, skipped;
  double forward_s = 0, step_s = 0;  // step: forward + backward (forward alone without a loss)
  bool backward = false;
  double flops = 0;
};

// The shape of most FLOPs (of the largest product of dims for copies, which count none).
const OpShape& largest(const OpEntry& e) {
  const auto size = [&](const OpShape& s) {
    double n = 1;
    for (size_t d : s.dims) n *= double(d);
    return e.flops && e.flops(s) > 0 ? e.flops(s) : n;
  };
  return *std::max_element(e.shapes.begin(), e.shapes.end(),
                           [&](const OpShape& a, const OpShape& b) { return size(a) < size(b); });
}

Row time_shape(Runtime& rt, const OpEntry& e, const OpShape& s, int reps) {
  Row row;
  row.entry = e.name;
  row.shape = s.label;
  const test::ShapeSetup setup(e, s, rt);
  if (!(row.skipped = setup.skipped()).empty()) return row;
  const auto built = test::build_entry(e, s);
  Executor ex(rt, built->g);
  test::set_entry_inputs(ex, *built, e.values(s));
  row.backward = built->g.loss().valid();
  row.forward_s = time_median(reps, [&] {
    ex.forward();
    rt.finish();
  });
  row.step_s = !row.backward ? row.forward_s : time_median(reps, [&] {
    ex.forward();
    ex.backward();
    rt.finish();
  });
  row.flops = e.flops ? e.flops(s) : 0.0;
  return row;
}

std::string gflops(double flops, double seconds) {
  if (flops <= 0 || seconds <= 0) return "-";
  std::ostringstream o;
  o << std::fixed << std::setprecision(2) << flops / seconds * 1e-9;
  return o.str();
}

std::string ms(double seconds) {
  std::ostringstream o;
  o << std::fixed << std::setprecision(3) << seconds * 1e3;
  return o.str();
}

// Entry and shape quoted: shape labels hold commas.
std::string csv_row(const std::string& entry, const std::string& shape, const Row& r, const std::string& rate) {
  return "\"" + entry + "\",\"" + shape + "\"," + ms(r.forward_s) + "," + (r.backward ? ms(r.step_s) : "") + "," +
         (rate == "-" ? "" : rate) + "\n";
}

}  // namespace

int ops(const Args& args) {
  const Options o(args, {{"filter", ""}, {"reps", "10"}, {"scale", "largest"}, {"csv", ""}, {"device", ""}});
  if (o.help()) {
    std::cout << o.usage("nova-bench ops")
              << "\n--filter: a regular expression searched in each entry's name (empty: every entry)\n"
                 "--scale: largest (each entry's largest shape) or all (every shape)\n";
    return 0;
  }
  std::regex filter;
  try {
    filter = std::regex(o.str("filter"));
  } catch (const std::regex_error&) {
    throw Error("--filter '" + o.str("filter") + "' is not a regular expression");
  }
  const std::string scale = o.str("scale");
  if (scale != "largest" && scale != "all") throw Error("--scale must be largest or all, got '" + scale + "'");
  const int reps = static_cast<int>(o.integer("reps"));
  if (reps < 1) throw Error("--reps must be at least 1");

  std::vector<const OpEntry*> entries;
  for (const OpEntry& e : test::op_table())
    if (std::regex_search(e.name, filter)) entries.push_back(&e);
  if (entries.empty()) throw Error("--filter '" + o.str("filter") + "' matches no entry of the op table");

  Runtime rt(select_device(o.str("device")));
  std::cout << "device " << rt.info().name << " (" << rt.info().type_name() << "); op table entries "
            << (scale == "all" ? "at every shape" : "at their largest shape") << ", median of " << reps
            << " after a warm-up; GFLOP/s: the entry's FLOP count of a forward + backward over fwd+bwd\n\n";
  const auto line = [](const std::string& entry, const std::string& shape, const std::string& fwd,
                       const std::string& step, const std::string& rate) {
    std::cout << std::left << std::setw(28) << entry << std::setw(46) << shape << std::right << std::setw(12) << fwd
              << std::setw(12) << step << std::setw(10) << rate << std::endl;
  };
  line("entry", "shape", "fwd ms", "fwd+bwd ms", "GFLOP/s");
  std::string csv = "entry,shape,forward_ms,forward_backward_ms,gflops_per_s\n";
  Row total;
  total.backward = true;
  for (const OpEntry* e : entries) {
    std::vector<const OpShape*> shapes;
    if (scale == "all")
      for (const OpShape& s : e->shapes) shapes.push_back(&s);
    else
      shapes.push_back(&largest(*e));
    for (const OpShape* s : shapes) {
      const Row r = time_shape(rt, *e, *s, reps);
      if (!r.skipped.empty()) {
        line(r.entry, r.shape, "skipped", "", "");
        std::cout << "  (" << r.skipped << ")\n";
        continue;
      }
      const std::string rate = gflops(r.flops, r.step_s);
      line(r.entry, r.shape, ms(r.forward_s), r.backward ? ms(r.step_s) : "-", rate);
      csv += csv_row(r.entry, r.shape, r, rate);
      total.forward_s += r.forward_s;
      total.step_s += r.step_s;
      total.flops += r.flops;
    }
  }
  const std::string rate = gflops(total.flops, total.step_s);
  line("total", "", ms(total.forward_s), ms(total.step_s), rate);
  csv += csv_row("total", "", total, rate);
  std::cout << "\n(fwd+bwd: forward alone for entries without a backward, shown '-'; the total adds those "
               "forwards)\n";
  if (!o.str("csv").empty()) {
    std::ofstream out(o.str("csv"));
    if (!(out << csv)) throw Error("cannot write --csv '" + o.str("csv") + "'");
    std::cout << "CSV: " << o.str("csv") << "\n";
  }
  return 0;
}

}  // namespace nova::bench

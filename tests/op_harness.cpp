#include "op_harness.hpp"

#include <boost/test/unit_test.hpp>
#include <cxxabi.h>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <regex>
#include <sstream>
#include <typeinfo>

#include "nova/graph/executor.hpp"

namespace nova::test {

namespace {

std::string demangled(const std::type_info& t) {
  int status = 0;
  std::unique_ptr<char, void (*)(void*)> name(abi::__cxa_demangle(t.name(), nullptr, nullptr, &status),
                                              std::free);
  std::string s = status == 0 ? name.get() : t.name();
  const size_t colons = s.rfind("::");
  return colons == std::string::npos ? s : s.substr(colons + 2);
}

}  // namespace

void check_entry(const OpEntry& e, const OpShape& s) {
  const ShapeSetup setup(e, s, runtime());
  if (!setup.skipped().empty()) {
    BOOST_TEST_MESSAGE(e.name << " " << s.label << ": " << setup.skipped());
    return;
  }
  if (const auto own = own_checks().find(e.name); own != own_checks().end()) {
    own->second(s);
    return;
  }
  BOOST_REQUIRE_MESSAGE(e.reference, e.name << " has neither a float64 reference nor a check of its own (op_table_checks.cpp)");
  const auto values = e.values(s);
  auto b = build_entry(e, s);
  Executor ex(runtime(), b->g, guarded_options());
  OpCase c{s, values, {}, {}, {}};
  c.targets = set_entry_inputs(ex, *b, values);
  ex.forward();
  for (const Tensor& t : b->op.outputs) c.outputs.push_back(ex.get(t));
  for (size_t k = 0; k < b->targets.size(); ++k) c.upstream.push_back(mse_upstream(c.outputs[k], c.targets[k]));
  std::vector<std::vector<float>> grads(values.size());
  if (b->g.loss().valid()) {
    ex.backward();
    for (size_t i = 0; i < values.size(); ++i)
      if (b->op.inputs[i].info().requires_grad) grads[i] = ex.get_grad(b->op.inputs[i]);
  }

  const auto forward = e.reference(c);
  BOOST_REQUIRE_EQUAL(forward.size(), c.outputs.size());
  for (size_t k = 0; k < forward.size(); ++k)
    if (!forward[k].want.empty())
      expect_close(c.outputs[k], forward[k].want, forward[k].tol.atol, forward[k].tol.rtol,
                   e.name + " forward, " + b->op.outputs[k].info().name);
  if (e.gradient) {
    const auto backward = e.gradient(c);
    BOOST_REQUIRE_EQUAL(backward.size(), values.size());
    for (size_t i = 0; i < backward.size(); ++i) {
      if (backward[i].want.empty()) continue;
      BOOST_REQUIRE(b->op.inputs[i].info().requires_grad);
      expect_close(grads[i], backward[i].want, backward[i].tol.atol, backward[i].tol.rtol,
                   "d " + e.name + " / d " + b->op.inputs[i].info().name);
    }
  }
  const bool fd = !s.no_fd && (s.fd || (e.fd && s.dims.at(0) <= e.fd_max_rows));
  if (fd)
    check_gradients(
        [&](Graph& g) {
          OpGraph op = e.build(g, s);
          return OpUnderTest{op.inputs, op.loss.valid() ? op.loss : op.outputs.at(0)};
        },
        values, s.fd ? *s.fd : *e.fd);
}

std::set<std::string> op_classes_built(const OpEntry& e, const OpShape& s) {
  Graph g;
  e.build(g, s);
  std::set<std::string> classes;
  for (size_t n = 0; n < g.node_count(); ++n) classes.insert(demangled(typeid(g.node(static_cast<int>(n)))));
  return classes;
}

std::set<std::string> library_op_classes() {
  namespace fs = std::filesystem;
  // `class Name [final] : public Base`, comments removed.
  const std::regex derived(R"(\bclass\s+(\w+)\s*(?:final\s*)?:\s*public\s+(?:nova::)?(\w+))");
  std::map<std::string, std::string> base_of;
  for (const char* dir : {"host", "include/nova"})
    for (const auto& f : fs::recursive_directory_iterator(fs::path(NOVA_SOURCE_DIR) / dir)) {
      const std::string ext = f.path().extension().string();
      if (ext != ".cpp" && ext != ".hpp") continue;
      std::ifstream in(f.path());
      std::stringstream ss;
      ss << in.rdbuf();
      std::string text = std::regex_replace(ss.str(), std::regex(R"(/\*[\s\S]*?\*/)"), " ");
      text = std::regex_replace(text, std::regex(R"(//[^\n]*)"), " ");
      for (std::sregex_iterator it(text.begin(), text.end(), derived), end; it != end; ++it)
        base_of[(*it)[1]] = (*it)[2];
    }
  std::set<std::string> bases, ops;
  for (const auto& [name, base] : base_of) {
    std::string b = base;
    for (int depth = 0; depth < 8 && b != "Op" && base_of.count(b); ++depth) b = base_of[b];
    if (b == "Op") ops.insert(name), bases.insert(base);
  }
  std::set<std::string> concrete;
  for (const std::string& c : ops)
    if (!bases.count(c)) concrete.insert(c);
  return concrete;
}

}  // namespace nova::test

#include "harness.hpp"

#include <boost/test/unit_test.hpp>
#include <cmath>
#include <memory>
#include <sstream>

#include "nova/loss/terms.hpp"

namespace nova::test {

Runtime& runtime() {
  static std::unique_ptr<Runtime> rt = std::make_unique<Runtime>(select_device());
  return *rt;
}

ExecutorOptions guarded_options() {
  ExecutorOptions o;
  o.guard_bytes = 1024;  // 256 floats: past any tile or vector width a kernel could overrun
  return o;
}

namespace {
// |a - e| / (atol + rtol |e|); an exact match is 0 even with zero tolerances, NaN is infinite.
double scaled_error(float actual, double expected, double atol, double rtol) {
  const double diff = std::fabs(actual - expected);
  if (diff == 0) return 0;
  const double e = diff / (atol + rtol * std::fabs(expected));
  return std::isnan(e) ? INFINITY : e;
}
}  // namespace

double max_scaled_error(const std::vector<float>& actual, const std::vector<double>& expected,
                        double atol, double rtol) {
  BOOST_REQUIRE_EQUAL(actual.size(), expected.size());
  double worst = 0;
  for (size_t i = 0; i < actual.size(); ++i) {
    const double e = scaled_error(actual[i], expected[i], atol, rtol);
    if (!(e <= worst)) worst = std::isnan(e) ? INFINITY : e;
  }
  return worst;
}

void expect_close(const std::vector<float>& actual, const std::vector<double>& expected,
                  double atol, double rtol, const std::string& what) {
  BOOST_REQUIRE_EQUAL(actual.size(), expected.size());
  size_t worst_i = 0;
  double worst = 0;
  for (size_t i = 0; i < actual.size(); ++i) {
    const double e = scaled_error(actual[i], expected[i], atol, rtol);
    if (!(e <= worst)) {
      worst = std::isnan(e) ? INFINITY : e;
      worst_i = i;
    }
  }
  BOOST_TEST(worst <= 1.0, what << ": element " << worst_i << " is " << actual[worst_i]
                                << ", expected " << expected[worst_i] << " (atol " << atol
                                << ", rtol " << rtol << ")");
}

double check_gradients(const BuildFn& build, const std::vector<std::vector<float>>& values,
                       const GradCheckOptions& o) {
  Graph g;
  OpUnderTest op = build(g);
  BOOST_REQUIRE_EQUAL(op.inputs.size(), values.size());
  Tensor target = g.input("target", op.output.shape());
  g.set_loss(mse(op.output, target));
  Executor ex(runtime(), g, guarded_options());
  for (size_t i = 0; i < values.size(); ++i) ex.set(op.inputs[i], values[i]);
  ex.set(target, random_floats(op.output.shape().numel(), -1.0f, 1.0f, o.seed));
  ex.forward();
  ex.backward();

  // Read every gradient before any further forward: activations reuse gradient memory.
  std::vector<std::vector<float>> analytic_all(op.inputs.size());
  for (size_t i = 0; i < op.inputs.size(); ++i)
    if (op.inputs[i].info().requires_grad) analytic_all[i] = ex.get_grad(op.inputs[i]);

  double worst = 0;
  for (size_t i = 0; i < op.inputs.size(); ++i) {
    if (!op.inputs[i].info().requires_grad) continue;
    const std::vector<float>& analytic = analytic_all[i];
    double scale = 1e-6;
    for (float a : analytic) scale = std::max(scale, static_cast<double>(std::fabs(a)));
    std::vector<float> x = values[i];
    const size_t n = x.size();
    const size_t stride = std::max<size_t>(1, n / o.max_components);
    for (size_t j = 0; j < n; j += stride) {
      const float x0 = x[j];
      x[j] = x0 + o.step;
      ex.set(op.inputs[i], x);
      ex.forward();
      const double lp = ex.loss();
      x[j] = x0 - o.step;
      ex.set(op.inputs[i], x);
      ex.forward();
      const double lm = ex.loss();
      x[j] = x0;
      const double fd = (lp - lm) / (2.0 * o.step);
      const double err = std::fabs(fd - analytic[j]) / scale;
      BOOST_TEST(err <= o.tolerance, "d loss / d " << op.inputs[i].info().name << "[" << j
                                                   << "]: analytic " << analytic[j]
                                                   << ", finite difference " << fd);
      worst = std::max(worst, err);
    }
    ex.set(op.inputs[i], x);
  }
  return worst;
}

std::vector<float> run_forward(const BuildFn& build, const std::vector<std::vector<float>>& values) {
  Graph g;
  OpUnderTest op = build(g);
  g.keep(op.output);
  Executor ex(runtime(), g, guarded_options());
  for (size_t i = 0; i < values.size(); ++i) ex.set(op.inputs[i], values[i]);
  ex.forward();
  return ex.get(op.output);
}

}  // namespace nova::test

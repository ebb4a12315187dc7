#pragma once
// The op test harness: a runtime per process, random data, comparisons against float64
// host references with stated tolerances, and finite-difference gradient checks.
// random_floats, to_double and activation_reference (harness_values.cpp) need no Boost: the
// op table's library (nova_op_table, which nova-bench links) takes them; the rest is
// harness.cpp's, in the test binary only.
#include <functional>
#include <string>
#include <vector>

#include "nova/graph/executor.hpp"
#include "nova/graph/graph.hpp"
#include "nova/loss/terms.hpp"
#include "nova/ops/encoding/positional_encoding.hpp"
#include "nova/ops/linalg/dense.hpp"
#include "nova/ops/tensor/tensor_ops.hpp"
#include "nova/runtime/runtime.hpp"

namespace nova::test {

// The device under test: NOVA_DEVICE if set, else nova's default choice.
Runtime& runtime();

// Executor options of the op checks: every tensor in a region of its own between guards that
// the executor checks after every op (ExecutorOptions::guard_bytes).
ExecutorOptions guarded_options();

std::vector<float> random_floats(size_t n, float lo, float hi, unsigned seed);
std::vector<double> to_double(const std::vector<float>& v);

// Largest |actual - expected| / (atol + rtol * |expected|); <= 1 means within tolerance.
// Reports the worst element through BOOST_TEST when it fails.
double max_scaled_error(const std::vector<float>& actual, const std::vector<double>& expected,
                        double atol, double rtol);
void expect_close(const std::vector<float>& actual, const std::vector<double>& expected,
                  double atol, double rtol, const std::string& what);

// A graph to check: `inputs` are graph inputs (those to differentiate are created with
// requires_grad = true), `output` is any tensor of it.
struct OpUnderTest {
  std::vector<Tensor> inputs;
  Tensor output;
};
using BuildFn = std::function<OpUnderTest(Graph&)>;

struct GradCheckOptions {
  float step = 1e-2f;         // central-difference step h
  size_t max_components = 48; // per input, spread evenly over it
  // Passes when |fd - analytic| <= tolerance * (max |analytic| over that input + 1e-6):
  // the error normalised by the gradient's scale, as ggml's test-backend-ops does.
  double tolerance = 2e-2;
  unsigned seed = 7;
};

// Runs a forward pass of the graph `build` makes on `values` (one vector per input) and
// returns its output (guarded).
std::vector<float> run_forward(const BuildFn& build, const std::vector<std::vector<float>>& values);

// Float64 value of an activation, the reference of the bias_act kernels.
double activation_reference(Activation a, double x);

// Builds the graph, appends loss = mse(output, random target), sets `values` (one vector per
// input), runs forward + backward (guarded) and compares the gradient of every input that
// requires one with central differences of the same device forward (in float32). Returns the
// worst normalised error over all checked components.
double check_gradients(const BuildFn& build, const std::vector<std::vector<float>>& values,
                       const GradCheckOptions& options = {});

}  // namespace nova::test

#pragma once
// The op table: every op of the library registered once with a small graph that runs it, its
// float64 host reference, the shapes to run it at (odd sizes: no multiple of a work-group or
// tile, and 1-row cases), tolerances with their reasons, and a FLOP count. One harness
// (op_harness.hpp) checks every entry; tests/test_op_table.cpp also fails for an op class of
// host/ that no entry builds. The table needs no Boost (library nova_op_table): the test
// binary checks it, and `nova-bench ops` times it (bench/bench_ops.cpp).
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "free_space_reference.hpp"
#include "harness.hpp"
#include "nova/graph/distributed.hpp"
#include "nova/graph/executor.hpp"
#include "nova/graph/graph.hpp"
#include "render_reference.hpp"

namespace nova::test {

// One problem size of an entry: its dimensions (the entry says what each means) and a variant
// (an activation, a backward mode...) where the entry has several.
struct OpShape {
  std::vector<size_t> dims;
  int variant = 0;
  std::string label;  // how a failure names it ("1009 rows x 3, L 4")
  // Central differences at this shape: the entry's (OpEntry::fd, fd_max_rows) when unset,
  // else these options; `no_fd` where the stencil cannot resolve the op (high frequencies).
  std::optional<GradCheckOptions> fd = std::nullopt;
  bool no_fd = false;
};

// The graph an entry builds: its inputs in the order of OpCase::values (those to
// differentiate created with requires_grad), the outputs compared with the reference, and,
// where the op's own scalar is the loss (loss ops), that loss. Without one the harness
// differentiates loss = sum_k mse(outputs[k], random target_k).
struct OpGraph {
  std::vector<Tensor> inputs;
  std::vector<Tensor> outputs;
  Tensor loss;
};

struct Tolerance {
  double atol = 0, rtol = 0;
};

// A float64 expectation for one device tensor, with its tolerance (|got - want| <= atol +
// rtol |want| element by element). An empty `want` skips that tensor.
struct Expected {
  std::vector<double> want;
  Tolerance tol;
};

// What the reference sees: the shape, the input values and what the device produced (some
// references take the device's own intermediate values, e.g. the upstream gradient
// 2 (out - target) / n of the mse the harness appends).
struct OpCase {
  const OpShape& shape;
  const std::vector<std::vector<float>>& values;
  std::vector<std::vector<float>> outputs;  // one per OpGraph::outputs
  std::vector<std::vector<float>> targets;  // per output, when the harness built the loss
  // d loss / d outputs[k] in float64 from the device outputs (empty with OpGraph::loss).
  std::vector<std::vector<double>> upstream;
};

struct OpEntry {
  std::string name;
  std::vector<OpShape> shapes;
  std::function<OpGraph(Graph&, const OpShape&)> build;
  std::function<std::vector<std::vector<float>>(const OpShape&)> values;
  // One Expected per output (float64 forward); may check the loss too by listing it last
  // in OpGraph::outputs.
  std::function<std::vector<Expected>(const OpCase&)> reference;
  // One Expected per input (empty `want`: not checked): the float64 gradient of the loss.
  std::function<std::vector<Expected>(const OpCase&)> gradient;
  // Central differences of the device forward (harness.hpp) on shapes with at most
  // `fd_max_rows` in dims[0] (the cost is two forwards per component); unset: the op is not
  // differentiable or its gradient is deliberately not the derivative (gradient_gate).
  std::optional<GradCheckOptions> fd;
  size_t fd_max_rows = 64;
  // Without `reference`: the entry's reference runs a whole problem (render_composite,
  // free_space_loss), and the test binary checks it with a check of its own, found by the
  // entry's name (op_table_checks.cpp).
  // Floating-point operations of one forward + backward at the shape (an estimate of the
  // arithmetic the kernels do; 0 for copies), for `nova-bench ops`.
  std::function<double(const OpShape&)> flops;
  // Where a shape needs the process set up before its executors are built (an environment
  // choice such as NOVA_HASH_BACKWARD) or a device feature: sets it up and returns "", or
  // returns why the device cannot run the shape (it is skipped). `restore` undoes the set-up.
  std::function<std::string(const OpShape&, const Runtime&)> prepare;
  std::function<void()> restore;
};

// An entry's `prepare` for one shape, undone when it goes; skipped() says why the device
// cannot run the shape, empty when it can.
class ShapeSetup {
 public:
  ShapeSetup(const OpEntry& entry, const OpShape& shape, const Runtime& rt);
  ~ShapeSetup();
  ShapeSetup(const ShapeSetup&) = delete;
  ShapeSetup& operator=(const ShapeSetup&) = delete;
  const std::string& skipped() const { return skipped_; }

 private:
  const OpEntry& entry_;
  std::string skipped_;
  bool prepared_ = false;
};

// An entry's graph ready to run: its outputs kept and, where it has inputs to differentiate
// and no loss of its own, loss = sum_k mse(outputs[k], targets[k]).
struct BuiltEntry {
  Graph g;
  OpGraph op;
  std::vector<Tensor> targets;
};
std::unique_ptr<BuiltEntry> build_entry(const OpEntry& entry, const OpShape& shape);
// Sets the entry's input values and random targets (uniform in [-1, 1], seeds 7, 8, ...) on
// an executor of the built graph; returns the targets.
std::vector<std::vector<float>> set_entry_inputs(Executor& ex, const BuiltEntry& built,
                                                 const std::vector<std::vector<float>>& values);

// Every entry, in registration order (one function per family).
const std::vector<OpEntry>& op_table();

void register_core_ops(std::vector<OpEntry>& table);
void register_loss_ops(std::vector<OpEntry>& table);
void register_ray_loss_ops(std::vector<OpEntry>& table);
void register_render_ops(std::vector<OpEntry>& table);
void register_grid_ops(std::vector<OpEntry>& table);
void register_motion_ops(std::vector<OpEntry>& table);

// The depth loss entry (op_table_ray_losses.cpp); with `ranks`, built through the moments
// summed over ranks (op_table_ranks.cpp uses it with twin ranks).
OpEntry depth_loss_entry(GradientReducer* ranks = nullptr);

// The free-space loss problems (op_table_ray_losses.cpp): dims N NeRFs, R rays, S samples;
// the case (variant 0 free_space_table_case, 1-3 free_space_random_case), its values in the
// graph's input order, and the graph of the case (margin, behind and noise from it, from the
// first object NeRF; `ranks` as free_space_loss takes it).
FreeSpaceCase free_space_case(const OpShape& s);
std::vector<std::vector<float>> free_space_values(const OpShape& s);
OpGraph free_space_graph(Graph& g, const OpShape& s, GradientReducer* ranks);
void register_rank_ops(std::vector<OpEntry>& table);
// The stand-in for a second rank that every graph of the table over ranks holds
// (twin_ranks_reducer.hpp).
GradientReducer& twin_ranks();

// The render_composite problem at a shape (op_table_render.cpp states the variants) and the
// seed of its loss's random targets (render_check.hpp).
struct RenderTableCase {
  RenderRefInput in;
  unsigned targets_seed = 0;
};
RenderTableCase render_table_case(const OpShape& s);
// render_composite of the case's inputs (a delta per NeRF and noise where the case has them)
// with its options.
struct RenderGraph {
  Tensor raw, delta, z, noise;
  RenderOutputs out;
};
RenderGraph render_table_graph(Graph& g, const RenderRefInput& in);
// The seed of instance_points' case at a shape (rays_reference.hpp's check_instance_points).
unsigned instance_points_seed(const OpShape& s);

// The row count of the odd-size sweep: a prime, more than any work-group nova chooses, so
// several groups and a partial last one on every device.
constexpr size_t kOddRows = 1009;

// Upstream gradient of mse(out, target): 2 (out - target) / n, from the device output.
std::vector<double> mse_upstream(const std::vector<float>& out, const std::vector<float>& target);
double max_abs(const std::vector<double>& v);
// Gradients against their float64 derivative applied to the device's upstream gradient:
// float32 rounding of one product chain is a few 1e-7 relative, so rtol 1e-5 with atol 1e-6
// of the largest reference magnitude.
Expected grad_expected(std::vector<double> want);

}  // namespace nova::test

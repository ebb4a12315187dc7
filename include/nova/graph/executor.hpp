#pragma once
// Runs a Graph on one Runtime: plans and allocates memory once, then runs forward and
// backward passes on the runtime's in-order queue, optionally timing every op and checking
// every tensor for NaN/Inf.
#include <map>
#include <string>
#include <vector>

#include "nova/graph/graph.hpp"
#include "nova/graph/memory_plan.hpp"
#include "nova/runtime/runtime.hpp"

namespace nova {

struct ExecutorOptions {
  bool profile = false;       // time every op with OpenCL profiling events
  bool check_finite = false;  // after every op, stop at the first NaN/Inf, naming op and tensor
  unsigned seed = 1;          // parameter initialisation
  // Tests only: every activation, gradient and workspace gets a region of its own (no reuse)
  // between two guards of at least this many bytes, filled with a pattern that every op is
  // checked not to have changed (an op writing past or before its tensor); so does every
  // parameter and parameter gradient in their arenas, whose guards an optimiser updating the
  // whole arena would overwrite (guarded executors are for checking ops). 0: the planned arena.
  size_t guard_bytes = 0;
};

// What an op sees while it runs: its tensors' buffers and shapes, and gradient slots.
class ExecContext {
 public:
  Runtime& rt;

  cl_mem in(size_t i) const;
  cl_mem out(size_t i) const;
  const Shape& in_shape(size_t i) const;
  const Shape& out_shape(size_t i) const;
  size_t num_inputs() const { return op_.inputs().size(); }
  size_t num_outputs() const { return op_.outputs().size(); }
  // Gradient of output i; nullptr when nothing on the path to the loss reads that output
  // (treat it as zero).
  cl_mem grad_out(size_t i) const;
  // Gradient of input i to write; nullptr when that input needs none.
  cl_mem grad_in(size_t i) const;
  // Whether grad_in(i) already holds a contribution to add to (otherwise overwrite it).
  bool accumulate_in(size_t i) const;
  cl_mem workspace() const { return workspace_; }

  // Rows in use of a tensor whose static row count (at capacity) is `rows`: `rows` scaled by
  // live / capacity of its extent, so that it works for flattened [B * M] counts as well as
  // per-batch M. Static tensors give `rows` back.
  size_t in_rows(size_t i, size_t rows) const;
  size_t out_rows(size_t i, size_t rows) const;
  // Sets the live row count of extent `e` (the producer of its packed tensors does this in
  // its forward); later ops of the pass, and the backward, see it.
  void set_extent(int e, size_t rows);

  Launch launch(const std::string& family, const std::string& name,
                const std::string& options = "") {
    return rt.launch(family, name, options);
  }

 private:
  friend class Executor;
  ExecContext(Runtime& r, class Executor& e, const Op& op, int node, cl_mem ws)
      : rt(r), ex_(e), op_(op), node_(node), workspace_(ws) {}
  class Executor& ex_;
  const Op& op_;
  int node_;
  cl_mem workspace_;
};

struct OpTiming {
  std::string type;
  int calls = 0;
  double ms = 0.0;
};

class Executor {
 public:
  Executor(Runtime& rt, Graph& graph, ExecutorOptions options = {});
  Executor(const Executor&) = delete;
  Executor& operator=(const Executor&) = delete;

  void forward();
  void backward();  // needs a loss (Graph::set_loss); runs after forward()

  void set(Tensor t, const std::vector<float>& values);
  void set(Tensor t, const float* values, size_t count);
  std::vector<float> get(Tensor t);       // a kept tensor, an input or a parameter
  // Gradient of a parameter or grad-requiring input. Input gradients share memory with
  // forward activations (their lifetimes do not overlap), so read them before the next
  // forward(); parameter gradients live in their own arena until the next backward().
  std::vector<float> get_grad(Tensor t);
  cl_mem buffer(Tensor t) const;
  cl_mem grad_buffer(Tensor t) const;  // nullptr if it has none
  float loss();
  // Live rows of extent e after the last forward (its capacity before any).
  size_t extent(int e) const { return extents_.at(e); }
  // Elements in use of a tensor: its numel, scaled down for a dynamic extent.
  size_t live_numel(TensorId t) const;

  Graph& graph() const { return graph_; }

  // All parameters live in one arena and their gradients in a second one with the same
  // layout, so an optimiser updates everything with one kernel.
  cl_mem parameter_arena() const { return param_arena_.get(); }
  cl_mem gradient_arena() const { return grad_arena_.get(); }
  size_t parameter_floats() const { return param_arena_floats_; }
  size_t parameter_count() const;  // real parameters, without alignment padding
  // Where a parameter starts in the arena, in floats (for an optimiser's per-range settings).
  size_t parameter_offset(Tensor t) const;

  // Peak bytes of the planned (reused) arena and what separate buffers would need.
  const MemoryPlan& plan() const { return plan_; }
  size_t parameter_bytes() const { return 2 * param_arena_floats_ * sizeof(float); }

  // Accumulated per-op-type timings (with options.profile), sorted by total time.
  std::vector<OpTiming> timings() const;
  void reset_timings() { timings_.clear(); }
  std::string profile_table() const;

 private:
  friend class ExecContext;
  void build_schedule();
  void allocate();
  void init_parameters(unsigned seed);
  void run_node(int node, Pass pass);
  void run_pass(const std::vector<int>& nodes, Pass pass);
  void check_finite(int node, Pass pass);
  void check_guards(int node, Pass pass);

  Runtime& rt_;
  Graph& graph_;
  ExecutorOptions options_;

  std::vector<int> backward_nodes_;  // in execution order
  std::vector<bool> has_grad_;       // per tensor
  // Per node and input slot: accumulate into the gradient rather than overwrite it.
  std::vector<std::vector<bool>> accumulate_;

  Buffer arena_, param_arena_, grad_arena_;
  size_t param_arena_floats_ = 0;
  std::vector<size_t> param_offsets_;  // per tensor, floats (parameters only)
  std::vector<Buffer> values_, grads_;                 // sub-buffers, per tensor
  std::vector<Buffer> fwd_workspace_, bwd_workspace_;  // per node
  MemoryPlan plan_;
  bool forward_done_ = false;
  // Per tensor: an input whose values were given (set(), or its buffer handed out to be
  // written). An input never given would be read as whatever its arena held before.
  mutable std::vector<bool> input_given_;
  void mark_given(TensorId t) const;
  enum GuardedArena { kActivationArena, kParameterArena, kGradientArena };
  struct Guard {
    size_t offset, bytes;  // in its arena
    int owner;             // index into guard_owner_: a tensor, a gradient, a workspace, a parameter
    bool after;            // the guard after the region (else before it)
    int arena;             // GuardedArena
  };
  std::vector<Guard> guards_;
  std::vector<std::string> guard_owner_;

  std::map<std::string, OpTiming> timings_;
  std::vector<size_t> extents_;  // live rows per graph extent
};

// Copies every parameter of `from` whose name starts with `prefix` into the parameter of `to`
// with the same name (graphs built by the same builders share names); the others stay.
void copy_parameters(Executor& to, Executor& from, const std::string& prefix = "");

}  // namespace nova

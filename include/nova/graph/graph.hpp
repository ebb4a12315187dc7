#pragma once
// The computation graph: float32 tensors and differentiable ops, built once per
// configuration and run many times by an Executor (executor.hpp).
//
// Every op implements one interface (forward, backward, what backward reads, scratch it
// needs). Gradients are reverse mode: the executor runs the backward of every op on the path
// from the parameters to the loss, in reverse order; an op writes the gradient of each input
// it is asked for, overwriting or accumulating as ExecContext::accumulate_in says, so a
// tensor read by several ops gets the sum without a zero-fill.
#include <cstddef>
#include <initializer_list>
#include <memory>
#include <string>
#include <vector>

namespace nova {

class Runtime;
class ExecContext;

using TensorId = int;

struct Shape {
  std::vector<size_t> dims;

  Shape() = default;
  Shape(std::initializer_list<size_t> d) : dims(d) {}
  explicit Shape(std::vector<size_t> d) : dims(std::move(d)) {}

  size_t rank() const { return dims.size(); }
  size_t operator[](size_t i) const { return dims.at(i); }
  size_t numel() const;
  size_t cols() const { return dims.empty() ? 1 : dims.back(); }  // last dimension
  size_t rows() const { return cols() ? numel() / cols() : 0; }   // all the others
  // The row dimension a dynamic extent binds: dims[rank - 2], or dims[0] for rank 1.
  size_t row_dim() const { return rank() >= 2 ? rank() - 2 : 0; }
  bool operator==(const Shape& o) const { return dims == o.dims; }
  std::string str() const;  // "[65536, 256]"
};

enum class TensorRole { Input, Parameter, Activation };

// How a parameter is initialised: uniform in [-bound, bound] (bound 0 gives zeros).
struct Init {
  float bound = 0.0f;
  static Init zeros() { return {0.0f}; }
  static Init uniform(float b) { return {b}; }
};

struct TensorInfo {
  std::string name;
  Shape shape;
  TensorRole role = TensorRole::Activation;
  bool requires_grad = false;
  bool keep = false;  // still readable after forward()/backward() returns
  Init init;
  int producer = -1;           // node index; -1 for inputs and parameters
  std::vector<int> consumers;  // node indices, in graph order
  // Dynamic extent (Graph::add_extent) bound to the row dimension, dims[rank - 2] (dims[0]
  // for rank 1): the tensor is allocated for the capacity, and a run uses only the leading
  // `extent value` rows of each batch, laid out densely ([B, live, C]). -1: static.
  int extent = -1;
};

class Graph;

// A handle to a tensor of a graph: cheap to copy.
struct Tensor {
  TensorId id = -1;
  Graph* graph = nullptr;

  bool valid() const { return graph && id >= 0; }
  // A reference into the graph's tensor table: adding a tensor may move it, so do not hold it
  // across graph building (shape() returns a copy for that reason).
  const TensorInfo& info() const;
  Shape shape() const { return info().shape; }
};

enum class Pass { Forward, Backward };

class Op {
 public:
  virtual ~Op() = default;
  // The op's kind, as shown in profiles and error messages ("linear", "bias_act", ...).
  virtual std::string type() const = 0;
  virtual void forward(ExecContext& ctx) = 0;
  virtual void backward(ExecContext& ctx) = 0;
  // Whether outputs whose row dimension matches a dynamic input's inherit its extent
  // (Graph::add). Ops whose output rows are not the input rows (a scatter back to a dense
  // layout) return false.
  virtual bool propagates_extent() const { return true; }
  // Whether the op's outputs take a gradient through input `index` (Graph::add): false for
  // an input the op treats as a constant, so that a gradient-free output starts no backward.
  virtual bool differentiable_in(size_t /*index*/) const { return true; }
  // Tensors (inputs or outputs of this op) its backward reads; the memory plan keeps them
  // alive until then. Default: every input and output.
  virtual std::vector<TensorId> saved_for_backward() const;
  // Scratch bytes the op needs during a pass; planned like any tensor.
  virtual size_t workspace_bytes(Runtime&, Pass) const { return 0; }

  const std::vector<TensorId>& inputs() const { return inputs_; }
  const std::vector<TensorId>& outputs() const { return outputs_; }

 private:
  friend class Graph;
  std::vector<TensorId> inputs_, outputs_;
};

class Graph {
 public:
  Graph() = default;
  Graph(const Graph&) = delete;
  Graph& operator=(const Graph&) = delete;

  // Data fed from the host before every run.
  Tensor input(const std::string& name, Shape shape, bool requires_grad = false);
  // Trainable weights; they live across runs in the executor's parameter arena.
  Tensor parameter(const std::string& name, Shape shape, Init init);
  // An intermediate result; ops create their outputs with this.
  Tensor activation(const std::string& name, Shape shape);

  // Adds `op` reading `inputs` and writing `outputs` (created with activation()).
  // Outputs require a gradient when any input does.
  void add(std::unique_ptr<Op> op, const std::vector<Tensor>& inputs,
           const std::vector<Tensor>& outputs);

  // A dynamic row count (packed samples): tensors bound to it are allocated for `capacity`
  // rows and the op that produces them sets the live count while the graph runs
  // (ExecContext::set_extent). Row-wise ops downstream inherit the binding.
  int add_extent(const std::string& name, size_t capacity);
  void bind_extent(Tensor t, int extent);
  size_t extent_count() const { return extent_capacity_.size(); }
  size_t extent_capacity(int e) const { return extent_capacity_.at(e); }
  const std::string& extent_name(int e) const { return extent_name_.at(e); }

  // The scalar whose gradient backward() computes. Without one the graph is inference-only.
  void set_loss(Tensor loss);
  Tensor loss() const { return loss_ >= 0 ? Tensor{loss_, const_cast<Graph*>(this)} : Tensor{}; }
  // Keeps a tensor readable after a run (outputs a caller wants to look at).
  void keep(Tensor t) { tensors_.at(t.id).keep = true; }

  const TensorInfo& tensor(TensorId id) const { return tensors_.at(id); }
  size_t tensor_count() const { return tensors_.size(); }
  Tensor handle(TensorId id) { return Tensor{id, this}; }
  const Op& node(int i) const { return *nodes_.at(i); }
  Op& node(int i) { return *nodes_.at(i); }
  size_t node_count() const { return nodes_.size(); }
  std::vector<Tensor> parameters();
  // Unique tensor name: `base` or `base.N`.
  std::string unique_name(const std::string& base);

 private:
  Tensor make(const std::string& name, Shape shape, TensorRole role, bool requires_grad);

  std::vector<TensorInfo> tensors_;
  std::vector<std::unique_ptr<Op>> nodes_;
  TensorId loss_ = -1;
  std::vector<size_t> extent_capacity_;
  std::vector<std::string> extent_name_;
};

}  // namespace nova

#include "nova/graph/graph.hpp"

#include <algorithm>
#include <sstream>

#include "nova/runtime/error.hpp"

namespace nova {

size_t Shape::numel() const {
  size_t n = 1;
  for (size_t d : dims) n *= d;
  return n;
}

std::string Shape::str() const {
  std::ostringstream s;
  s << "[";
  for (size_t i = 0; i < dims.size(); ++i) s << (i ? ", " : "") << dims[i];
  s << "]";
  return s.str();
}

const TensorInfo& Tensor::info() const {
  if (!valid()) throw Error("use of an empty tensor handle", kExitInternal);
  return graph->tensor(id);
}

std::vector<TensorId> Op::saved_for_backward() const {
  std::vector<TensorId> all = inputs_;
  all.insert(all.end(), outputs_.begin(), outputs_.end());
  return all;
}

std::string Graph::unique_name(const std::string& base) {
  const auto taken = [&](const std::string& n) {
    return std::any_of(tensors_.begin(), tensors_.end(),
                       [&](const TensorInfo& t) { return t.name == n; });
  };
  if (!taken(base)) return base;
  for (int i = 1;; ++i)
    if (auto n = base + "." + std::to_string(i); !taken(n)) return n;
}

Tensor Graph::make(const std::string& name, Shape shape, TensorRole role, bool requires_grad) {
  if (shape.numel() == 0)
    throw Error("tensor '" + name + "' has an empty shape " + shape.str(), kExitInternal);
  TensorInfo t;
  t.name = unique_name(name);
  t.shape = std::move(shape);
  t.role = role;
  t.requires_grad = requires_grad;
  tensors_.push_back(std::move(t));
  return Tensor{static_cast<TensorId>(tensors_.size() - 1), this};
}

Tensor Graph::input(const std::string& name, Shape shape, bool requires_grad) {
  return make(name, std::move(shape), TensorRole::Input, requires_grad);
}

Tensor Graph::parameter(const std::string& name, Shape shape, Init init) {
  Tensor t = make(name, std::move(shape), TensorRole::Parameter, true);
  tensors_[t.id].init = init;
  return t;
}

Tensor Graph::activation(const std::string& name, Shape shape) {
  return make(name, std::move(shape), TensorRole::Activation, false);
}

void Graph::add(std::unique_ptr<Op> op, const std::vector<Tensor>& inputs,
                const std::vector<Tensor>& outputs) {
  const int index = static_cast<int>(nodes_.size());
  bool any_grad = false;
  for (const Tensor& t : inputs) {
    if (t.graph != this) throw Error(op->type() + ": input from another graph", kExitInternal);
    op->inputs_.push_back(t.id);
    auto& c = tensors_[t.id].consumers;
    if (c.empty() || c.back() != index) c.push_back(index);
    any_grad = any_grad || (tensors_[t.id].requires_grad && op->differentiable_in(op->inputs_.size() - 1));
  }
  for (const Tensor& t : outputs) {
    auto& info = tensors_.at(t.id);
    if (t.graph != this || info.role != TensorRole::Activation || info.producer >= 0)
      throw Error(op->type() + ": output '" + info.name + "' must be a fresh activation",
                  kExitInternal);
    info.producer = index;
    info.requires_grad = any_grad;
    op->outputs_.push_back(t.id);
    if (!op->propagates_extent() || info.extent >= 0) continue;
    for (const Tensor& in : inputs) {
      const TensorInfo& src = tensors_[in.id];
      if (src.extent < 0 || src.shape.rank() != info.shape.rank()) continue;
      const size_t d = src.shape.row_dim();
      if (info.shape.dims[d] != src.shape.dims[d]) continue;
      info.extent = src.extent;
      break;
    }
  }
  nodes_.push_back(std::move(op));
}

int Graph::add_extent(const std::string& name, size_t capacity) {
  if (capacity == 0) throw Error("extent '" + name + "' has no capacity", kExitInternal);
  extent_capacity_.push_back(capacity);
  extent_name_.push_back(name);
  return static_cast<int>(extent_capacity_.size() - 1);
}

void Graph::bind_extent(Tensor t, int extent) {
  TensorInfo& info = tensors_.at(t.id);
  if (extent < 0 || static_cast<size_t>(extent) >= extent_capacity_.size() ||
      info.shape.dims[info.shape.row_dim()] != extent_capacity_[extent])
    throw Error("tensor '" + info.name + "' " + info.shape.str() + " cannot bind extent " +
                    std::to_string(extent), kExitInternal);
  info.extent = extent;
}

void Graph::set_loss(Tensor loss) {
  if (loss.graph != this || loss.shape().numel() != 1)
    throw Error("the loss must be a scalar tensor of this graph", kExitInternal);
  loss_ = loss.id;
  tensors_[loss.id].keep = true;
}

std::vector<Tensor> Graph::parameters() {
  std::vector<Tensor> out;
  for (size_t i = 0; i < tensors_.size(); ++i)
    if (tensors_[i].role == TensorRole::Parameter) out.push_back({static_cast<TensorId>(i), this});
  return out;
}

}  // namespace nova

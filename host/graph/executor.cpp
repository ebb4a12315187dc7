#include "nova/graph/executor.hpp"
#include "nova/tuning/tuning.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <iomanip>
#include <random>
#include <sstream>

namespace nova {

// ---- ExecContext -----------------------------------------------------------------------------

cl_mem ExecContext::in(size_t i) const { return ex_.values_.at(op_.inputs().at(i)).get(); }
cl_mem ExecContext::out(size_t i) const { return ex_.values_.at(op_.outputs().at(i)).get(); }
const Shape& ExecContext::in_shape(size_t i) const {
  return ex_.graph_.tensor(op_.inputs().at(i)).shape;
}
const Shape& ExecContext::out_shape(size_t i) const {
  return ex_.graph_.tensor(op_.outputs().at(i)).shape;
}
cl_mem ExecContext::grad_out(size_t i) const {
  const TensorId t = op_.outputs().at(i);
  return ex_.has_grad_[t] ? ex_.grads_[t].get() : nullptr;
}
cl_mem ExecContext::grad_in(size_t i) const {
  const TensorId t = op_.inputs().at(i);
  return ex_.has_grad_[t] ? ex_.grads_[t].get() : nullptr;
}
bool ExecContext::accumulate_in(size_t i) const { return ex_.accumulate_.at(node_).at(i); }

namespace {
size_t live_rows(const TensorInfo& t, const std::vector<size_t>& extents, const Graph& g, size_t rows) {
  if (t.extent < 0) return rows;
  return rows / g.extent_capacity(t.extent) * extents.at(t.extent);
}
}  // namespace

size_t ExecContext::in_rows(size_t i, size_t rows) const {
  return live_rows(ex_.graph_.tensor(op_.inputs().at(i)), ex_.extents_, ex_.graph_, rows);
}
size_t ExecContext::out_rows(size_t i, size_t rows) const {
  return live_rows(ex_.graph_.tensor(op_.outputs().at(i)), ex_.extents_, ex_.graph_, rows);
}
void ExecContext::set_extent(int e, size_t rows) {
  if (rows > ex_.graph_.extent_capacity(e))
    throw Error("extent '" + ex_.graph_.extent_name(e) + "': " + std::to_string(rows) +
                    " rows exceed its capacity " + std::to_string(ex_.graph_.extent_capacity(e)),
                kExitInternal);
  ex_.extents_.at(e) = rows;
}

size_t Executor::live_numel(TensorId t) const {
  const TensorInfo& info = graph_.tensor(t);
  return live_rows(info, extents_, graph_, info.shape.numel());
}

void copy_parameters(Executor& to, Executor& from, const std::string& prefix) {
  for (Tensor p : to.graph().parameters()) {
    const std::string& name = p.info().name;
    if (name.rfind(prefix, 0) != 0) continue;
    for (Tensor q : from.graph().parameters())
      if (q.info().name == name) to.set(p, from.get(q));
  }
}

namespace {
// A float NaN with a payload no kernel computes: a guard float that still holds it was not
// written.
constexpr uint32_t kGuardPattern = 0x7fa5a5a5u;

void fill_guard_pattern(Runtime& rt, cl_mem arena, size_t bytes) {
  float pattern;
  std::memcpy(&pattern, &kGuardPattern, sizeof(pattern));
  rt.fill_floats(arena, pattern, bytes);
}
}  // namespace

// ---- schedule and memory ---------------------------------------------------------------------

Executor::Executor(Runtime& rt, Graph& graph, ExecutorOptions options)
    : rt_(rt), graph_(graph), options_(options) {
  for (size_t e = 0; e < graph_.extent_count(); ++e) extents_.push_back(graph_.extent_capacity(static_cast<int>(e)));
  build_schedule();
  allocate();
  init_parameters(options.seed);
}

void Executor::build_schedule() {
  const size_t nt = graph_.tensor_count();
  const int nn = static_cast<int>(graph_.node_count());
  has_grad_.assign(nt, false);
  accumulate_.assign(nn, {});
  for (int n = 0; n < nn; ++n) accumulate_[n].assign(graph_.node(n).inputs().size(), false);
  const Tensor loss = graph_.loss();
  if (!loss.valid()) return;

  // Tensors on a path to the loss; among them, those that need a gradient.
  std::vector<bool> on_path(nt, false);
  on_path[loss.id] = true;
  for (int n = nn - 1; n >= 0; --n) {
    const Op& op = graph_.node(n);
    const bool feeds_loss = std::any_of(op.outputs().begin(), op.outputs().end(),
                                        [&](TensorId t) { return on_path[t]; });
    if (feeds_loss)
      for (TensorId t : op.inputs()) on_path[t] = true;
  }
  for (size_t t = 0; t < nt; ++t) has_grad_[t] = on_path[t] && graph_.tensor(t).requires_grad;

  for (int n = nn - 1; n >= 0; --n) {
    const Op& op = graph_.node(n);
    if (std::any_of(op.outputs().begin(), op.outputs().end(),
                    [&](TensorId t) { return has_grad_[t]; }))
      backward_nodes_.push_back(n);
  }
  // The first writer of a gradient (in backward order) overwrites, later ones add.
  std::vector<bool> written(nt, false);
  for (int n : backward_nodes_) {
    const auto& ins = graph_.node(n).inputs();
    for (size_t s = 0; s < ins.size(); ++s) {
      if (!has_grad_[ins[s]]) continue;
      accumulate_[n][s] = written[ins[s]];
      written[ins[s]] = true;
    }
  }
}

void Executor::allocate() {
  const size_t nt = graph_.tensor_count();
  const int nn = static_cast<int>(graph_.node_count());
  const int nb = static_cast<int>(backward_nodes_.size());
  // Steps: forward nodes 0..nn-1, the loss-gradient seed at nn, backward nodes after it.
  const int seed_step = nn;
  const int end_step = nn + 1 + nb;
  std::vector<int> bwd_step(nn, -1);
  for (int j = 0; j < nb; ++j) bwd_step[backward_nodes_[j]] = nn + 1 + j;

  std::vector<Lifetime> lives;
  std::vector<std::pair<int, int>> owner;  // (kind, index): 0 value, 1 grad, 2 fwd ws, 3 bwd ws
  std::vector<int> last_value(nt, -1);
  for (size_t t = 0; t < nt; ++t) {
    const TensorInfo& info = graph_.tensor(t);
    if (info.role == TensorRole::Parameter) continue;
    int first = info.role == TensorRole::Input ? 0 : info.producer;
    int last = first;
    for (int c : info.consumers) last = std::max(last, c);
    if (info.keep || info.role == TensorRole::Input) last = end_step;
    last_value[t] = last;
  }
  for (int n = 0; n < nn; ++n) {
    if (bwd_step[n] < 0) continue;
    for (TensorId t : graph_.node(n).saved_for_backward())
      if (graph_.tensor(t).role != TensorRole::Parameter)
        last_value[t] = std::max(last_value[t], bwd_step[n]);
  }
  for (size_t t = 0; t < nt; ++t) {
    const TensorInfo& info = graph_.tensor(t);
    if (info.role == TensorRole::Parameter) continue;
    const size_t bytes = info.shape.numel() * sizeof(float);
    lives.push_back({bytes, info.role == TensorRole::Input ? 0 : info.producer, last_value[t]});
    owner.push_back({0, static_cast<int>(t)});
    if (!has_grad_[t]) continue;
    // A gradient lives from its first writer (or the seed) to its producer's backward.
    int first = end_step;
    for (int c : info.consumers)
      if (bwd_step[c] >= 0) first = std::min(first, bwd_step[c]);
    if (static_cast<TensorId>(t) == graph_.loss().id) first = seed_step;
    const int last = info.producer >= 0 && !info.keep ? bwd_step[info.producer] : end_step;
    lives.push_back({bytes, first, std::max(first, last)});
    owner.push_back({1, static_cast<int>(t)});
  }
  for (int n = 0; n < nn; ++n) {
    if (size_t ws = graph_.node(n).workspace_bytes(rt_, Pass::Forward)) {
      lives.push_back({ws, n, n});
      owner.push_back({2, n});
    }
    if (bwd_step[n] >= 0)
      if (size_t ws = graph_.node(n).workspace_bytes(rt_, Pass::Backward)) {
        lives.push_back({ws, bwd_step[n], bwd_step[n]});
        owner.push_back({3, n});
      }
  }

  const size_t align = std::max<size_t>(rt_.info().base_addr_align_bytes, 256);
  // Guarded (tests): one region per lifetime for the whole run, a guard on both sides; the
  // region before a sub-buffer is whole alignment units so that the sub-buffer stays aligned.
  const size_t guard = (options_.guard_bytes + align - 1) / align * align;
  std::vector<size_t> bytes(lives.size());
  for (size_t i = 0; i < lives.size(); ++i) {
    bytes[i] = lives[i].bytes;
    if (!guard) continue;
    lives[i] = {guard + bytes[i] + guard, 0, end_step};
    const auto [kind, index] = owner[i];
    guard_owner_.push_back(kind == 0   ? "tensor '" + graph_.tensor(index).name + "'"
                           : kind == 1 ? "the gradient of '" + graph_.tensor(index).name + "'"
                                       : std::string(kind == 2 ? "forward" : "backward") +
                                             " workspace of node " + std::to_string(index));
  }
  plan_ = plan_memory(lives, align);
  if (plan_.peak_bytes > rt_.info().max_alloc_bytes)
    throw Error("the graph needs " + std::to_string(plan_.peak_bytes >> 20) +
                    " MiB in one buffer, more than " + rt_.info().name + " allows (" +
                    std::to_string(rt_.info().max_alloc_bytes >> 20) +
                    " MiB): use a smaller batch",
                kExitUsage);
  // A guarded executor keeps the arena whatever the device: its regions never overlap, and
  // the guards are checked in it.
  const bool separate = !guard && arena_layout(rt_.info()) == ArenaLayout::Separate;
  if (!separate) arena_ = rt_.alloc(plan_.peak_bytes);
  values_.resize(nt);
  grads_.resize(nt);
  fwd_workspace_.resize(nn);
  bwd_workspace_.resize(nn);
  if (guard) {
    fill_guard_pattern(rt_, arena_.get(), plan_.peak_bytes);
    for (size_t i = 0; i < lives.size(); ++i) {
      guards_.push_back({plan_.offsets[i], guard, static_cast<int>(i), false, kActivationArena});
      // Workspaces may end inside a float: the guard after one starts at the next float.
      const size_t end = plan_.offsets[i] + guard + bytes[i], after = (end + 3) / 4 * 4;
      guards_.push_back({after, guard - (after - end), static_cast<int>(i), true, kActivationArena});
    }
  }
  for (size_t i = 0; i < lives.size(); ++i) {
    Buffer b = separate ? rt_.alloc(bytes[i]) : rt_.sub_buffer(arena_, plan_.offsets[i] + guard, bytes[i]);
    auto [kind, index] = owner[i];
    (kind == 0 ? values_ : kind == 1 ? grads_ : kind == 2 ? fwd_workspace_ : bwd_workspace_)[index] =
        std::move(b);
  }

  // Parameters and their gradients: two arenas with the same layout. Guarded: each parameter
  // between two guards in both arenas, the regions zeroed (a gradient no op writes reads 0).
  const size_t align_floats = align / sizeof(float), guard_floats = guard / sizeof(float);
  std::vector<size_t> offsets(nt, 0);
  size_t floats = 0;
  for (size_t t = 0; t < nt; ++t) {
    if (graph_.tensor(t).role != TensorRole::Parameter) continue;
    offsets[t] = floats + guard_floats;
    floats += guard_floats + (graph_.tensor(t).shape.numel() + align_floats - 1) / align_floats * align_floats +
              guard_floats;
  }
  param_arena_floats_ = floats;
  param_offsets_ = offsets;
  if (floats == 0) return;
  param_arena_ = rt_.alloc(floats * sizeof(float));
  grad_arena_ = rt_.alloc(floats * sizeof(float));
  for (cl_mem a : {param_arena_.get(), grad_arena_.get()}) {
    if (guard)
      fill_guard_pattern(rt_, a, floats * sizeof(float));
    else
      rt_.fill_zero(a, floats * sizeof(float));
  }
  for (size_t t = 0; t < nt; ++t) {
    if (graph_.tensor(t).role != TensorRole::Parameter) continue;
    const size_t bytes = graph_.tensor(t).shape.numel() * sizeof(float), at = offsets[t] * sizeof(float);
    values_[t] = rt_.sub_buffer(param_arena_, at, bytes);
    grads_[t] = rt_.sub_buffer(grad_arena_, at, bytes);
    if (!guard) continue;
    for (int arena : {kParameterArena, kGradientArena}) {
      rt_.fill_zero(arena == kParameterArena ? param_arena_.get() : grad_arena_.get(), bytes, at);
      guard_owner_.push_back((arena == kParameterArena ? "parameter '" : "the gradient of parameter '") +
                             graph_.tensor(t).name + "'");
      const int owner = static_cast<int>(guard_owner_.size()) - 1;
      guards_.push_back({at - guard, guard, owner, false, arena});
      guards_.push_back({at + bytes, guard, owner, true, arena});
    }
  }
}

size_t Executor::parameter_offset(Tensor t) const {
  if (graph_.tensor(t.id).role != TensorRole::Parameter)
    throw Error("parameter_offset: '" + graph_.tensor(t.id).name + "' is not a parameter", kExitInternal);
  return param_offsets_.at(t.id);
}

void Executor::init_parameters(unsigned seed) {
  std::mt19937 rng(seed);
  for (Tensor p : graph_.parameters()) {
    const float bound = p.info().init.bound;
    std::vector<float> v(p.shape().numel(), 0.0f);
    std::uniform_real_distribution<float> u(-bound, bound);
    if (bound > 0)
      for (float& x : v) x = u(rng);
    set(p, v);
  }
}

size_t Executor::parameter_count() const {
  size_t n = 0;
  for (size_t t = 0; t < graph_.tensor_count(); ++t)
    if (graph_.tensor(t).role == TensorRole::Parameter) n += graph_.tensor(t).shape.numel();
  return n;
}

// ---- running ---------------------------------------------------------------------------------

namespace {
cl_ulong event_end(cl_event e) {
  cl_ulong t = 0;
  cl_check(clGetEventProfilingInfo(e, CL_PROFILING_COMMAND_END, sizeof(t), &t, nullptr),
           "clGetEventProfilingInfo");
  return t;
}
}  // namespace

void Executor::run_node(int n, Pass pass) {
  Op& op = graph_.node(n);
  ExecContext ctx(rt_, *this, op, n,
                  (pass == Pass::Forward ? fwd_workspace_ : bwd_workspace_)[n].get());
  if (pass == Pass::Forward)
    op.forward(ctx);
  else
    op.backward(ctx);
  if (options_.check_finite) check_finite(n, pass);
  if (!guards_.empty()) check_guards(n, pass);
}

void Executor::run_pass(const std::vector<int>& nodes, Pass pass) {
  // With profiling, a marker after every op: op time = end of its marker - end of the last.
  const bool timed = options_.profile && rt_.profiling();
  std::vector<cl_event> marks;
  const auto mark = [&] {
    cl_event e;
    cl_check(clEnqueueMarkerWithWaitList(rt_.queue(), 0, nullptr, &e), "clEnqueueMarker");
    marks.push_back(e);
  };
  if (timed) mark();
  for (int n : nodes) {
    run_node(n, pass);
    if (timed) mark();
  }
  if (!timed) return;
  rt_.finish();
  for (size_t j = 0; j < nodes.size(); ++j) {
    const std::string type =
        graph_.node(nodes[j]).type() + (pass == Pass::Backward ? " (backward)" : "");
    auto& t = timings_[type];
    t.type = type;
    t.calls++;
    t.ms += (event_end(marks[j + 1]) - event_end(marks[j])) * 1e-6;
  }
  for (cl_event e : marks) clReleaseEvent(e);
}

void Executor::forward() {
  input_given_.resize(graph_.tensor_count(), false);
  for (size_t t = 0; t < graph_.tensor_count(); ++t)
    if (graph_.tensor(t).role == TensorRole::Input && !input_given_[t])
      throw Error("forward(): input '" + graph_.tensor(t).name + "' was never set", kExitInternal);
  if (options_.check_finite)
    for (size_t t = 0; t < graph_.tensor_count(); ++t)
      if (graph_.tensor(t).role == TensorRole::Input) {
        const auto v = get(graph_.handle(static_cast<TensorId>(t)));
        for (size_t i = 0; i < v.size(); ++i)
          if (!std::isfinite(v[i]))
            throw Error("input '" + graph_.tensor(t).name + "' holds a non-finite value at " +
                        std::to_string(i));
      }
  std::vector<int> nodes(graph_.node_count());
  for (size_t n = 0; n < nodes.size(); ++n) nodes[n] = static_cast<int>(n);
  run_pass(nodes, Pass::Forward);
  forward_done_ = true;
}

void Executor::backward() {
  const Tensor loss = graph_.loss();
  if (!loss.valid()) throw Error("backward() on a graph without a loss", kExitInternal);
  if (!forward_done_) throw Error("backward() before forward()", kExitInternal);
  forward_done_ = false;
  if (!has_grad_[loss.id]) return;  // the loss depends on no parameter
  // Queued, not a blocking write: the backward is enqueued while the forward still runs.
  rt_.fill_floats(grads_[loss.id].get(), 1.0f, sizeof(float));
  run_pass(backward_nodes_, Pass::Backward);
}

void Executor::check_finite(int n, Pass pass) {
  const Op& op = graph_.node(n);
  const auto check = [&](TensorId t, cl_mem m, const char* what) {
    const size_t count = live_numel(t);
    if (count == 0) return;
    const auto v = rt_.download_floats(m, count);
    for (size_t i = 0; i < count; ++i)
      if (!std::isfinite(v[i])) {
        std::ostringstream s;
        s << "non-finite value " << v[i] << " at element " << i << " of " << what << " '"
          << graph_.tensor(t).name << "' after the " << (pass == Pass::Forward ? "forward" : "backward")
          << " of op '" << op.type() << "' (node " << n << ")";
        throw Error(s.str(), kExitInternal);
      }
  };
  if (pass == Pass::Forward) {
    for (TensorId t : op.outputs()) check(t, values_[t].get(), "tensor");
  } else {
    for (TensorId t : op.inputs())
      if (has_grad_[t]) check(t, grads_[t].get(), "the gradient of");
  }
}

void Executor::check_guards(int n, Pass pass) {
  const Buffer* buffers[] = {&arena_, &param_arena_, &grad_arena_};
  const size_t bytes[] = {plan_.peak_bytes, param_arena_floats_ * sizeof(float), param_arena_floats_ * sizeof(float)};
  std::vector<uint32_t> arenas[3];
  for (const Guard& g : guards_) {
    std::vector<uint32_t>& arena = arenas[g.arena];
    if (arena.empty()) {
      arena.resize(bytes[g.arena] / sizeof(uint32_t));
      rt_.download(buffers[g.arena]->get(), arena.data(), arena.size() * sizeof(uint32_t));
    }
    for (size_t i = g.offset / 4; i < (g.offset + g.bytes) / 4; ++i)
      if (arena[i] != kGuardPattern) {
        std::ostringstream s;
        s << "the " << (pass == Pass::Forward ? "forward" : "backward") << " of op '"
          << graph_.node(n).type() << "' (node " << n << ") wrote "
          << (g.after ? "past the end" : "before the start") << " of " << guard_owner_.at(g.owner)
          << " (float " << (g.after ? (i * 4 - g.offset) / 4 : (g.offset + g.bytes - i * 4) / 4 - 1)
          << (g.after ? " after it" : " before it") << " changed)";
        throw Error(s.str(), kExitInternal);
      }
  }
}

// ---- host access -----------------------------------------------------------------------------

void Executor::set(Tensor t, const float* values, size_t count) {
  const TensorInfo& info = graph_.tensor(t.id);
  if (count != info.shape.numel())
    throw Error("tensor '" + info.name + "' has shape " + info.shape.str() + " (" +
                    std::to_string(info.shape.numel()) + " values) but " + std::to_string(count) +
                    " were given",
                kExitInternal);
  // In queue order, without waiting for the device: the host prepares the next step's data
  // while the current one runs.
  rt_.upload_async(values_[t.id].get(), values, count * sizeof(float));
  mark_given(t.id);
}

void Executor::mark_given(TensorId t) const {
  input_given_.resize(graph_.tensor_count(), false);
  input_given_[t] = true;
}

void Executor::set(Tensor t, const std::vector<float>& values) {
  set(t, values.data(), values.size());
}

std::vector<float> Executor::get(Tensor t) {
  const TensorInfo& info = graph_.tensor(t.id);
  if (info.role == TensorRole::Activation && !info.keep)
    throw Error("tensor '" + info.name + "' is not kept after a run (Graph::keep)", kExitInternal);
  // A packed tensor: its live rows (the rest of its capacity holds nothing of this run).
  const size_t n = live_numel(t.id);
  return n ? rt_.download_floats(values_[t.id].get(), n) : std::vector<float>{};
}

std::vector<float> Executor::get_grad(Tensor t) {
  const TensorInfo& info = graph_.tensor(t.id);
  const bool readable = info.role == TensorRole::Parameter ||
                        (info.role == TensorRole::Input && has_grad_[t.id]);
  if (!readable || !grads_[t.id])
    throw Error("tensor '" + info.name + "' has no gradient to read", kExitInternal);
  return rt_.download_floats(grads_[t.id].get(), info.shape.numel());
}

cl_mem Executor::buffer(Tensor t) const {
  mark_given(t.id);  // the caller writes it (or reads it: then it was given before)
  return values_.at(t.id).get();
}
cl_mem Executor::grad_buffer(Tensor t) const {
  return has_grad_.at(t.id) || graph_.tensor(t.id).role == TensorRole::Parameter
             ? grads_.at(t.id).get()
             : nullptr;
}

float Executor::loss() {
  const Tensor l = graph_.loss();
  if (!l.valid()) throw Error("the graph has no loss", kExitInternal);
  return get(l).at(0);
}

std::vector<OpTiming> Executor::timings() const {
  std::vector<OpTiming> v;
  for (const auto& [k, t] : timings_) v.push_back(t);
  std::sort(v.begin(), v.end(), [](const OpTiming& a, const OpTiming& b) { return a.ms > b.ms; });
  return v;
}

std::string Executor::profile_table() const {
  const auto v = timings();
  double total = 0;
  for (const auto& t : v) total += t.ms;
  std::ostringstream s;
  s << std::left << std::setw(28) << "op" << std::right << std::setw(8) << "calls"
    << std::setw(12) << "total ms" << std::setw(9) << "share" << "\n";
  for (const auto& t : v)
    s << std::left << std::setw(28) << t.type << std::right << std::setw(8) << t.calls
      << std::setw(12) << std::fixed << std::setprecision(2) << t.ms << std::setw(8)
      << std::setprecision(1) << (total > 0 ? 100.0 * t.ms / total : 0.0) << "%\n";
  s << std::left << std::setw(28) << "total" << std::right << std::setw(8) << "" << std::setw(12)
    << std::fixed << std::setprecision(2) << total << "\n";
  return s.str();
}

}  // namespace nova

#pragma once
// The compositing op's benchmark problem, shared by nova-bench render and devices: 1 + K
// NeRFs' plausible raw fields at R rays x S samples through render_composite, with the losses
// that train through it (colour and masks), on one device.
#include <memory>
#include <vector>

#include "nova/graph/executor.hpp"
#include "nova/render/render_composite.hpp"

namespace nova::bench {

class CompositeProblem {
 public:
  CompositeProblem(Runtime& rt, size_t nerfs, size_t rays, size_t samples);
  size_t nerfs() const { return N_; }
  size_t rays() const { return R_; }
  size_t samples() const { return S_; }
  // The inputs: raw [N, R, S, 5] (rgb and blend logits in [-3, 3], sigma in [-1, 4]),
  // delta and z [R, S]; the targets are 0.5 everywhere.
  const std::vector<float>& raw() const { return raw_; }
  const std::vector<float>& delta() const { return delta_; }
  const std::vector<float>& z() const { return z_; }

  // Median seconds of `repeats` forwards after a warm-up; of `repeats` backwards, each after
  // an untimed forward.
  double forward_seconds(int repeats);
  double backward_seconds(int repeats);
  // One forward and backward: the colour [R, 3], masks [N, R] and d loss / d raw.
  struct Outputs {
    std::vector<float> rgb, mask, grad_raw;
  };
  Outputs run();

 private:
  Runtime& rt_;
  size_t N_, R_, S_;
  std::vector<float> raw_, delta_, z_;
  Graph g_;
  Tensor raw_in_;
  RenderOutputs out_;
  std::unique_ptr<Executor> ex_;
};

}  // namespace nova::bench

#pragma once
// Adam with bias correction over an executor's whole parameter arena, and the learning-rate
// schedule of the reference code (exponential decay).
#include <cmath>
#include <cstddef>

#include "nova/runtime/runtime.hpp"

namespace nova {

struct AdamConfig {
  float beta1 = 0.9f;
  float beta2 = 0.999f;
  float eps = 1e-8f;
};

// lr(step) = lr0 * factor^(step / decay_steps): the reference decays by 0.1 over 300k steps.
struct ExponentialDecay {
  float lr0 = 5e-4f;
  float factor = 0.1f;
  double decay_steps = 300000;
  float operator()(long step) const {
    return lr0 * static_cast<float>(std::pow(factor, static_cast<double>(step) / decay_steps));
  }
};

class Adam {
 public:
  Adam(Runtime& rt, size_t count, AdamConfig config = {});
  // One update of params from grads (both `count` floats) at learning rate lr.
  void step(cl_mem params, cl_mem grads, float lr);
  long steps() const { return t_; }
  // Moments and step, for checkpoints.
  cl_mem first_moment() const { return m_.get(); }
  cl_mem second_moment() const { return v_.get(); }
  void set_steps(long t) { t_ = t; }
  // One range of the parameters (floats [first, first + count)) steps at `scale` times the
  // learning rate: a quantity that must move slower than the networks (a trajectory).
  void scale_range(size_t first, size_t count, float scale);
  size_t count() const { return count_; }

 private:
  Runtime& rt_;
  size_t count_;
  AdamConfig config_;
  Buffer m_, v_;
  long t_ = 0;
  size_t scaled_first_ = 0, scaled_end_ = 0;
  float scale_ = 1.0f;
};

}  // namespace nova

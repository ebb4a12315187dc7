#include <cmath>

#include "nova/runtime/error.hpp"
#include "nova/train/optim.hpp"

namespace nova {

Adam::Adam(Runtime& rt, size_t count, AdamConfig config)
    : rt_(rt), count_(count), config_(config) {
  m_ = rt.alloc(count * sizeof(float));
  v_ = rt.alloc(count * sizeof(float));
  rt.fill_zero(m_.get(), count * sizeof(float));
  rt.fill_zero(v_.get(), count * sizeof(float));
}

void Adam::step(cl_mem params, cl_mem grads, float lr) {
  ++t_;
  // Bias corrections in double: 1 - beta^t loses digits in float for small t.
  const double bc1 = 1.0 - std::pow(static_cast<double>(config_.beta1), static_cast<double>(t_));
  const double bc2 = 1.0 - std::pow(static_cast<double>(config_.beta2), static_cast<double>(t_));
  rt_.launch("optim", "adam_step")
      .arg(params).arg(grads).arg(m_).arg(v_).arg(static_cast<unsigned>(count_))
      .arg(static_cast<float>(lr / bc1)).arg(config_.beta1).arg(config_.beta2)
      .arg(static_cast<float>(std::sqrt(bc2))).arg(config_.eps)
      .arg(static_cast<unsigned>(scaled_first_)).arg(static_cast<unsigned>(scaled_end_)).arg(scale_)
      .run(count_);
}

void Adam::scale_range(size_t first, size_t count, float scale) {
  if (first + count > count_ || !(scale >= 0.0f))
    throw Error("Adam: scaled range [" + std::to_string(first) + ", " + std::to_string(first + count) +
                    ") or scale outside the " + std::to_string(count_) + " parameters", kExitInternal);
  scaled_first_ = first;
  scaled_end_ = first + count;
  scale_ = scale;
}

}  // namespace nova

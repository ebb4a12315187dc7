#include "composite_problem.hpp"

#include <algorithm>
#include <chrono>
#include <random>

#include "bench.hpp"
#include "nova/loss/terms.hpp"

namespace nova::bench {

CompositeProblem::CompositeProblem(Runtime& rt, size_t nerfs, size_t rays, size_t samples)
    : rt_(rt), N_(nerfs), R_(rays), S_(samples) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(-3, 3), us(-1, 4);
  raw_.resize(N_ * R_ * S_ * 5);
  delta_.resize(R_ * S_);
  z_.resize(R_ * S_);
  for (size_t e = 0; e < raw_.size(); ++e) raw_[e] = e % 5 == 3 ? us(rng) : u(rng);
  for (size_t e = 0; e < R_ * S_; ++e) {
    delta_[e] = e % S_ + 1 == S_ ? 1e10f : 1.0f / static_cast<float>(S_);
    z_[e] = static_cast<float>(e % S_) / static_cast<float>(S_);
  }
  raw_in_ = g_.input("raw", Shape{N_, R_ * S_, 5}, true);
  Tensor delta = g_.input("delta", Shape{R_, S_}), z = g_.input("z", Shape{R_, S_}),
         target = g_.input("target", Shape{R_, 3}), masks = g_.input("masks", Shape{N_, R_});
  out_ = render_composite(raw_in_, delta, z);
  g_.keep(out_.rgb);
  g_.keep(out_.mask);
  g_.set_loss(weighted_sum({mse(out_.rgb, target), mse(out_.mask, masks)}, {1.0f, 1.0f}));
  ex_ = std::make_unique<Executor>(rt_, g_);
  ex_->set(raw_in_, raw_);
  ex_->set(delta, delta_);
  ex_->set(z, z_);
  ex_->set(target, std::vector<float>(R_ * 3, 0.5f));
  ex_->set(masks, std::vector<float>(N_ * R_, 0.5f));
}

double CompositeProblem::forward_seconds(int repeats) {
  return time_median(repeats, [&] {
    ex_->forward();
    rt_.finish();
  });
}

double CompositeProblem::backward_seconds(int repeats) {
  std::vector<double> t;
  for (int i = 0; i <= repeats; ++i) {
    ex_->forward();
    rt_.finish();
    const auto a = std::chrono::steady_clock::now();
    ex_->backward();
    rt_.finish();
    if (i > 0) t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

CompositeProblem::Outputs CompositeProblem::run() {
  ex_->forward();
  Outputs o{ex_->get(out_.rgb), ex_->get(out_.mask), {}};
  ex_->backward();
  o.grad_raw = ex_->get_grad(raw_in_);
  return o;
}

}  // namespace nova::bench

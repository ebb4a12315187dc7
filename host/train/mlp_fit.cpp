#include "nova/train/mlp_fit.hpp"

#include <chrono>
#include <cmath>
#include <random>

#include "nova/graph/executor.hpp"
#include "nova/loss/terms.hpp"
#include "nova/ops/encoding/positional_encoding.hpp"
#include "nova/train/optim.hpp"

namespace nova {

std::array<float, 4> smooth_target(float x, float y, float z) {
  return {0.5f + 0.3f * std::sin(2.0f * x) * std::cos(1.5f * y),
          0.5f + 0.25f * std::cos(x + 2.0f * z),
          0.5f + 0.2f * x * y + 0.2f * std::sin(3.0f * z),
          0.5f + 0.3f * std::tanh(x - y + 0.5f * z)};
}

void sample_smooth_function(std::mt19937& rng, size_t n, int outputs, std::vector<float>& points,
                            std::vector<float>& target) {
  if (outputs < 1 || outputs > 4) throw Error("sample_smooth_function: outputs must be 1 to 4", kExitUsage);
  const size_t k = static_cast<size_t>(outputs);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  points.resize(n * 3);
  target.resize(n * k);
  for (size_t i = 0; i < n; ++i) {
    for (int d = 0; d < 3; ++d) points[i * 3 + d] = u(rng);
    const auto t = smooth_target(points[i * 3], points[i * 3 + 1], points[i * 3 + 2]);
    for (size_t d = 0; d < k; ++d) target[i * k + d] = t[d];
  }
}

MlpFitResult fit_smooth_function(Runtime& rt, const MlpFitConfig& config,
                                 const FitProgress& progress) {
  if (config.mlp.outputs != 4 || config.mlp.networks != 1)
    throw Error("fit_smooth_function: the MLP must have 4 outputs and one network", kExitUsage);
  Graph g;
  Tensor points = g.input("points", Shape{config.batch, 3});
  Tensor target = g.input("target", Shape{config.batch, 4});
  const Mlp mlp = build_mlp(positional_encoding(points, config.frequencies), config.mlp);
  g.set_loss(mse(mlp.output, target));

  ExecutorOptions eo;
  eo.profile = config.profile;
  eo.seed = config.seed;
  Executor ex(rt, g, eo);
  Adam adam(rt, ex.parameter_floats());
  std::mt19937 rng(config.seed);

  std::vector<float> p, t, eval_p, eval_t;
  sample_smooth_function(rng, config.batch, 4, eval_p, eval_t);
  const auto evaluate = [&] {
    ex.set(points, eval_p);
    ex.set(target, eval_t);
    ex.forward();
    return static_cast<double>(ex.loss());
  };

  MlpFitResult r;
  r.parameters = ex.parameter_count();
  r.arena_bytes = ex.plan().peak_bytes;
  r.unplanned_bytes = ex.plan().total_bytes;
  r.initial_loss = evaluate();
  ex.reset_timings();

  const auto start = std::chrono::steady_clock::now();
  for (int step = 0; step < config.steps; ++step) {
    sample_smooth_function(rng, config.batch, 4, p, t);
    ex.set(points, p);
    ex.set(target, t);
    ex.forward();
    ex.backward();
    adam.step(ex.parameter_arena(), ex.gradient_arena(), config.lr);
    if (progress && (step % 25 == 0 || step + 1 == config.steps)) {
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      progress(step, ex.loss(), s);
    }
  }
  rt.finish();
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  r.samples_per_second = config.steps * static_cast<double>(config.batch) / r.seconds;
  if (config.profile) r.profile = ex.profile_table();
  r.final_loss = evaluate();
  return r;
}

}  // namespace nova

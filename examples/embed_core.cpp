// Embedding nova in an HPC job: the program links nova_core alone (OpenCL + CLBlast, no
// OpenCV, no Boost) and trains a small NeRF-style MLP on the OpenCL device with the public
// headers in include/nova: a runtime, a graph (positional encoding -> MLP -> mse), the
// executor's forward and backward, and Adam over the parameter arena.
//
//   embed_core [steps]   device: NOVA_DEVICE (index "P:D" or a name), else the first GPU
//
// Exit 0 when the held-out loss falls at least 4-fold, 1 when it does not, 2 for bad input
// (a bad step count, no OpenCL device). CTest runs it (examples/CMakeLists.txt).
#include <cstdlib>
#include <exception>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "nova/runtime/error.hpp"
#include "nova/graph/executor.hpp"
#include "nova/graph/graph.hpp"
#include "nova/model/mlp.hpp"
#include "nova/train/mlp_fit.hpp"
#include "nova/ops/encoding/positional_encoding.hpp"
#include "nova/loss/terms.hpp"
#include "nova/train/optim.hpp"
#include "nova/runtime/runtime.hpp"

namespace {

int parse_steps(int argc, char** argv) {
  if (argc < 2) return 200;
  char* end = nullptr;
  const long v = std::strtol(argv[1], &end, 10);
  if (*end != '\0' || v < 1 || v > 1000000)
    throw nova::Error(std::string("steps must be an integer in [1, 1000000], got '") + argv[1] + "'");
  return static_cast<int>(v);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const int steps = parse_steps(argc, argv);
    nova::Runtime rt(nova::select_device());  // NOVA_DEVICE, else the first GPU, else a CPU

    // The graph is built once; 1009 rows is no multiple of any work-group size.
    const size_t batch = 1009;
    nova::Graph g;
    nova::Tensor points = g.input("points", nova::Shape{batch, 3});
    nova::Tensor target = g.input("target", nova::Shape{batch, 2});
    nova::MlpConfig mlp;
    mlp.depth = 3;
    mlp.width = 64;
    mlp.skip = -1;
    mlp.outputs = 2;
    const nova::Mlp net = nova::build_mlp(nova::positional_encoding(points, 6), mlp);
    g.set_loss(nova::mse(net.output, target));

    nova::Executor ex(rt, g);
    nova::Adam adam(rt, ex.parameter_floats());
    std::mt19937 rng(1);
    std::vector<float> p, t, eval_p, eval_t;
    nova::sample_smooth_function(rng, batch, 2, eval_p, eval_t);  // what a job reads from its data
    const auto held_out_loss = [&] {
      ex.set(points, eval_p);
      ex.set(target, eval_t);
      ex.forward();
      return static_cast<double>(ex.loss());
    };

    const double before = held_out_loss();
    for (int step = 0; step < steps; ++step) {
      nova::sample_smooth_function(rng, batch, 2, p, t);
      ex.set(points, p);
      ex.set(target, t);
      ex.forward();
      ex.backward();
      adam.step(ex.parameter_arena(), ex.gradient_arena(), 5e-3f);
    }
    const double after = held_out_loss();
    std::cout << "embed_core: " << rt.info().name << " (" << rt.info().type_name() << "), "
              << ex.parameter_count() << " parameters, " << steps << " steps: held-out loss "
              << before << " -> " << after << "\n";
    if (!(after * 4 < before)) {
      std::cerr << "embed_core: the loss did not fall 4-fold\n";
      return nova::kExitInternal;
    }
    return 0;
  } catch (const nova::Error& e) {
    std::cerr << "embed_core: error: " << e.what() << "\n";
    return e.exit_code();
  } catch (const std::exception& e) {
    std::cerr << "embed_core: error: " << e.what() << "\n";
    return nova::kExitInternal;
  }
}

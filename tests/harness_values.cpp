// The Boost-free part of the harness (harness.hpp): random inputs and float64 activations,
// which the op table's entries use and nova-bench links through nova_op_table.
#include <cmath>
#include <random>

#include "harness.hpp"

namespace nova::test {

std::vector<float> random_floats(size_t n, float lo, float hi, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(lo, hi);
  std::vector<float> v(n);
  for (float& x : v) x = u(rng);
  return v;
}

std::vector<double> to_double(const std::vector<float>& v) { return {v.begin(), v.end()}; }

double activation_reference(Activation a, double x) {
  switch (a) {
    case Activation::ReLU: return x > 0 ? x : 0;
    case Activation::Sigmoid: return 1 / (1 + std::exp(-x));
    case Activation::Softplus: return std::log1p(std::exp(x));
    default: return x;
  }
}

}  // namespace nova::test

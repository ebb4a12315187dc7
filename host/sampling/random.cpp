// The device random ops (random.hpp): forward only, their values are data.
#include "nova/sampling/random.hpp"

#include "nova/runtime/error.hpp"
#include "nova/graph/executor.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

class RandomOp final : public Op {
 public:
  RandomOp(const char* kernel, size_t n, size_t cols, RandomStream rs, float scale)
      : kernel_(kernel), n_(n), cols_(cols), rs_(std::move(rs)), scale_(scale) {}
  std::string type() const override { return kernel_; }

  void forward(ExecContext& ctx) override {
    const uint64_t c = rs_.counter ? rs_.counter->value : 0;
    ctx.launch("random", kernel_)
        .arg(ctx.out(0)).arg(detail::u32(n_, "random values")).arg(detail::u32(cols_, "random columns"))
        .arg(detail::u32(rs_.global_cols ? rs_.global_cols : cols_, "random global columns"))
        .arg(detail::u32(rs_.col_offset, "random column offset")).arg(rs_.seed).arg(rs_.stream)
        .arg(static_cast<unsigned>(c & 0xffffffffu)).arg(static_cast<unsigned>(c >> 32)).arg(scale_)
        .run(n_);
  }
  void backward(ExecContext&) override {}
  std::vector<TensorId> saved_for_backward() const override { return {}; }

 private:
  const char* kernel_;
  size_t n_, cols_;
  RandomStream rs_;
  float scale_;
};

Tensor random_op(const char* kernel, Graph& g, const std::string& name, Shape shape, RandomStream rs, float scale) {
  if (shape.numel() == 0) throw Error(std::string(kernel) + ": '" + name + "' has no elements", kExitInternal);
  const size_t cols = rs.view_cols ? rs.view_cols : shape.cols();
  if (shape.numel() % cols != 0)
    throw Error(std::string(kernel) + ": rows of " + std::to_string(cols) + " do not tile " + shape.str(), kExitInternal);
  if (rs.global_cols && rs.col_offset + cols > rs.global_cols)
    throw Error(std::string(kernel) + ": columns [" + std::to_string(rs.col_offset) + ", " +
                std::to_string(rs.col_offset + cols) + ") exceed rows of " + std::to_string(rs.global_cols), kExitInternal);
  Tensor y = g.activation(name, shape);
  g.add(std::make_unique<RandomOp>(kernel, shape.numel(), cols, std::move(rs), scale), {}, {y});
  return y;
}

constexpr uint32_t kM0 = 0xD2511F53u, kM1 = 0xCD9E8D57u, kW0 = 0x9E3779B9u, kW1 = 0xBB67AE85u;

}  // namespace

Tensor random_uniform(Graph& g, const std::string& name, Shape shape, RandomStream rs, float scale) {
  return random_op("random_uniform", g, name, std::move(shape), std::move(rs), scale);
}

Tensor random_normal(Graph& g, const std::string& name, Shape shape, RandomStream rs, float scale) {
  return random_op("random_normal", g, name, std::move(shape), std::move(rs), scale);
}

std::array<uint32_t, 4> philox4x32_10(std::array<uint32_t, 4> c, std::array<uint32_t, 2> k) {
  for (int round = 0; round < 10; ++round) {
    if (round > 0) {
      k[0] += kW0;
      k[1] += kW1;
    }
    const uint64_t p0 = uint64_t{kM0} * c[0], p1 = uint64_t{kM1} * c[2];
    c = {static_cast<uint32_t>(p1 >> 32) ^ c[1] ^ k[0], static_cast<uint32_t>(p1),
         static_cast<uint32_t>(p0 >> 32) ^ c[3] ^ k[1], static_cast<uint32_t>(p0)};
  }
  return c;
}

}  // namespace nova

// The depth loss up to scale and shift (kernels/depth_loss.cl).
#include "nova/graph/executor.hpp"
#include "nova/loss/terms.hpp"
#include "ops/tensor/op_util.hpp"
#include "loss/rank_moments.hpp"

namespace nova {
namespace {

class DepthLossOp final : public Op {
 public:
  explicit DepthLossOp(size_t rays) : rays_(rays) {}
  std::string type() const override { return "depth_loss"; }

  void forward(ExecContext& ctx) override {
    ctx.launch("depth_loss", "depth_loss_forward")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(ctx.out(0))
        .arg(detail::u32(rays_, "rays")).run(1);
  }

  void backward(ExecContext& ctx) override {
    cl_mem gl = ctx.grad_out(0), dp = ctx.grad_in(0);
    if (!gl || !dp) return;
    ctx.launch("depth_loss", "depth_loss_backward")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(gl).arg(dp)
        .arg(detail::u32(rays_, "rays")).arg(static_cast<int>(ctx.accumulate_in(0))).run(1);
  }

  std::vector<TensorId> saved_for_backward() const override { return inputs(); }

 private:
  size_t rays_;
};

}  // namespace

Tensor depth_loss(Tensor depth, Tensor target, Tensor valid, GradientReducer* ranks) {
  const Shape& s = depth.shape();
  if (s.rank() != 1 || !(target.shape() == s) || !(valid.shape() == s))
    throw Error("depth_loss: depth " + s.str() + ", target " + target.shape().str() +
                    " and valid " + valid.shape().str() + " must all be the same [R]",
                kExitInternal);
  if (target.info().requires_grad || valid.info().requires_grad)
    throw Error("depth_loss: target and valid are data and cannot take a gradient", kExitInternal);
  // One process keeps its single kernel (and its arithmetic, bit for bit).
  if (ranks && ranks->size() > 1)
    return detail::depth_loss_from_moments(detail::batch_moments(depth, target, valid, Tensor{}, *ranks));
  Graph& g = *depth.graph;
  Tensor y = g.activation(depth.info().name + ".depth_loss", Shape{1});
  g.add(std::make_unique<DepthLossOp>(s[0]), {depth, target, valid}, {y});
  return y;
}

}  // namespace nova

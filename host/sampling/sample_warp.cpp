#include "nova/sampling/sample_warp.hpp"

#include <algorithm>

#include "nova/graph/executor.hpp"
#include "nova/runtime/error.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

class ObjectSampleWarpOp final : public Op {
 public:
  ObjectSampleWarpOp(size_t objects, const MotionOptions& o, float share, float reach)
      : objects_(objects), o_(o), share_(share), reach_(reach) {}
  std::string type() const override { return "object_sample_warp"; }
  void forward(ExecContext& ctx) override {
    ctx.launch("rigid_motion", "object_sample_warp")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(ctx.out(0))
        .arg(detail::u32(objects_, "objects")).arg(static_cast<unsigned>(o_.frames))
        .arg(o_.ndc_near).arg(share_).arg(reach_).arg(static_cast<float>(kMinWarpInterval))
        .run(1);
  }
  // Where samples go is data: the warp takes no gradient, and sends none to the motion.
  void backward(ExecContext&) override {}
  bool differentiable_in(size_t) const override { return false; }
  std::vector<TensorId> saved_for_backward() const override { return {}; }

 private:
  size_t objects_;
  MotionOptions o_;
  float share_, reach_;
};

}  // namespace

std::vector<float> sample_warp(const std::vector<DepthInterval>& intervals, double share) {
  if (!(share >= 0.0 && share < 1.0)) throw Error("sample_warp: share must be in [0, 1)", kExitInternal);
  std::vector<DepthInterval> kept;
  for (DepthInterval i : intervals) {
    if (!(i.hi > i.lo)) continue;  // also drops NaN bounds
    if (i.hi - i.lo < kMinWarpInterval) {
      const double mid = 0.5 * (i.lo + i.hi);
      i = {mid - 0.5 * kMinWarpInterval, mid + 0.5 * kMinWarpInterval};
    }
    i.lo = std::max(i.lo, 0.0);
    i.hi = std::min(i.hi, 1.0);
    if (i.hi > i.lo) kept.push_back(i);
  }
  const double even = kept.empty() ? 1.0 : 1.0 - share;
  const double each = kept.empty() ? 0.0 : share / static_cast<double>(kept.size());
  std::vector<double> bounds{0.0, 1.0};
  for (const DepthInterval& i : kept) {
    bounds.push_back(i.lo);
    bounds.push_back(i.hi);
  }
  std::sort(bounds.begin(), bounds.end());
  bounds.erase(std::unique(bounds.begin(), bounds.end()), bounds.end());
  // The mixture's cumulative distribution at each bound: its density is constant between two.
  std::vector<double> cdf{0.0};
  for (size_t b = 0; b + 1 < bounds.size(); ++b) {
    const double a = bounds[b], z = bounds[b + 1], mid = 0.5 * (a + z);
    double density = even;
    for (const DepthInterval& i : kept)
      if (mid > i.lo && mid < i.hi) density += each / (i.hi - i.lo);
    cdf.push_back(cdf.back() + density * (z - a));
  }
  const size_t W = sample_warp_knots(intervals.size());
  std::vector<float> knots;
  knots.reserve(W * 2);
  for (size_t b = 0; b < bounds.size(); ++b) {
    knots.push_back(static_cast<float>(cdf[b] / cdf.back()));
    knots.push_back(static_cast<float>(bounds[b]));
  }
  knots[knots.size() - 2] = 1.0f;  // exactly: the sums reach 1 only up to rounding
  while (knots.size() < W * 2) {
    knots.push_back(1.0f);
    knots.push_back(1.0f);
  }
  return knots;
}

Tensor object_sample_warp(Tensor motion, Tensor radius, Tensor times, const MotionOptions& o, double share,
                          double reach) {
  const std::string op = "object_sample_warp";
  if (!o.ndc) detail::bad_op(op, "samples crowd about objects on forward-facing (NDC) scenes only");
  if (!(share >= 0.0 && share < 1.0)) detail::bad_op(op, "share must be in [0, 1)");
  if (!(reach > 0.0)) detail::bad_op(op, "reach must be positive");
  const size_t K = radius.shape().rank() == 1 ? radius.shape()[0] : 0;
  if (K == 0 || K > kMaxWarpObjects)
    detail::bad_op(op, "radius must be [K] with 1 <= K <= " + std::to_string(kMaxWarpObjects) + ", got " +
                           radius.shape().str());
  const Shape motion_shape = K == 1 ? Shape{static_cast<size_t>(o.frames), 6}
                                    : Shape{K, static_cast<size_t>(o.frames), 6};
  if (!(motion.shape() == motion_shape))
    detail::bad_op(op, "motion must be " + motion_shape.str() + ", got " + motion.shape().str());
  if (times.shape().numel() != K) detail::bad_op(op, "times must hold one time per object, got " + times.shape().str());
  detail::require_data(op, times);
  Graph& g = *motion.graph;
  Tensor warp = g.activation("samples.warp", Shape{sample_warp_knots(K), 2});
  g.add(std::make_unique<ObjectSampleWarpOp>(K, o, static_cast<float>(share), static_cast<float>(reach)),
        {motion, radius, times}, {warp});
  return warp;
}

}  // namespace nova

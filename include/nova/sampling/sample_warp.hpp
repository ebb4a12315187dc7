#pragma once
// Where a ray's samples go when part of them should crowd into a few depth ranges (where the
// moving objects stand): a piecewise-linear warp of the stratified depths, the same for every
// ray of a view, that stratified_samples applies (rays.hpp). Depths are fractions of the sampled
// range [near, far] (NDC t for forward-facing scenes, where a depth range is the same t-range
// on every ray).
//
// The samples' density is a mixture: a share `1 - share` spread evenly over [0, 1] (what the
// background needs) and `share` split evenly over the intervals, each evenly over itself. The
// warp is that mixture's inverse cumulative distribution, as knots (u, t), u and t increasing
// from (0, 0) to (1, 1); the stratified u of sample i then lands at t = warp(u).
#include <cstddef>
#include <vector>

#include "nova/graph/graph.hpp"
#include "nova/sampling/rigid_motion.hpp"

namespace nova {

struct DepthInterval {
  double lo = 0.0, hi = 0.0;  // fractions of [near, far]; lo >= hi is no interval
};

// Knots of a warp with `intervals` intervals: 2 per interval and the two ends (a graph input
// has a fixed shape; unused knots repeat (1, 1)).
inline size_t sample_warp_knots(size_t intervals) { return 2 * intervals + 2; }

// The narrowest interval the warp keeps: one narrower is widened about its middle to this, so
// its samples stay a finite density (a thin object still gets a slab of them).
inline constexpr double kMinWarpInterval = 1e-3;

// [sample_warp_knots(intervals.size()), 2] floats, row-major (u, t). Intervals are clipped to
// [0, 1]; one left empty there gives its share back to the even spread. share in [0, 1).
std::vector<float> sample_warp(const std::vector<DepthInterval>& intervals, double share);

// The same on the device for a training step, whose objects move with a learned motion:
// motion [K, F, 6] (or [F, 6]; the parameter, read, never differentiated), radius [K] (world
// units), times [K, 1] -> the warp [sample_warp_knots(K), 2] whose intervals hold the world
// depths within reach * radius[k] of object k's translation at its time (depth_interval and
// object_sample_warp in object_samples.hpp are the host's, and this op's reference).
// Forward-facing scenes (options.ndc), at most kMaxWarpObjects objects.
inline constexpr size_t kMaxWarpObjects = 64;
Tensor object_sample_warp(Tensor motion, Tensor radius, Tensor times, const MotionOptions& options, double share,
                          double reach);

}  // namespace nova

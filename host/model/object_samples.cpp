#include "nova/model/object_samples.hpp"

#include <algorithm>
#include <cmath>

#include "nova/runtime/error.hpp"

namespace nova {

bool uses_object_samples(const ModelConfig& c, const RayGeometry& geo, int objects) {
  return c.object_samples > 0 && c.field.object_box && c.field.motion == ObjectMotion::Rigid && geo.ndc &&
         objects > 0;
}

DepthInterval box_depth_interval(const float* box_row, const Mat34& world_to_canonical, const RayGeometry& geo) {
  if (!geo.ndc) throw Error("box_depth_interval: the scene is not forward-facing (NDC)", kExitInternal);
  const Mat34 to_world = invert_rigid(world_to_canonical);
  DepthInterval out{1.0, 0.0};
  for (int i = 0; i < 8; ++i) {
    Vec3 q;
    for (int d = 0; d < 3; ++d) {
      const double half = std::exp(-static_cast<double>(box_row[3 + d]));
      q[static_cast<size_t>(d)] = box_row[d] + ((i >> d) & 1 ? half : -half);
    }
    if (q[2] >= 1.0) {  // NDC's far end: infinite depth
      out.hi = 1.0;
      continue;
    }
    // NDC -> world (near plane 1, as rays_generate and instance_points): z = 2 / (q_z - 1).
    const double z = 2.0 / (q[2] - 1.0);
    const Vec3 canonical{q[0] * z / geo.ax, q[1] * z / geo.ay, z};
    const Vec3 world = apply_rigid(to_world, canonical);
    // t = 1 + 1 / z for a point in front of the near plane (z < -1); nearer is t = 0.
    const double t = world[2] < -1.0 ? 1.0 + 1.0 / world[2] : 0.0;
    out.lo = std::min(out.lo, t);
    out.hi = std::max(out.hi, t);
  }
  return out;
}

std::vector<float> object_sample_warp(const ModelConfig& c, const RayGeometry& geo,
                                      const std::vector<const float*>& box_rows,
                                      const std::vector<Mat34>& world_to_canonical) {
  if (box_rows.size() != world_to_canonical.size())
    throw Error("object_sample_warp: one map per box", kExitInternal);
  std::vector<DepthInterval> intervals;
  for (size_t k = 0; k < box_rows.size(); ++k)
    intervals.push_back(box_depth_interval(box_rows[k], world_to_canonical[k], geo));
  return sample_warp(intervals, static_cast<double>(c.object_samples) / c.samples);
}

}  // namespace nova

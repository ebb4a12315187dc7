#include "nova/model/object_samples.hpp"

#include "nova/runtime/error.hpp"

namespace nova {

bool uses_object_samples(const ModelConfig& c, const RayGeometry& geo, int objects) {
  return c.object_samples > 0 && c.field.motion == ObjectMotion::Rigid && geo.ndc && objects > 0;
}

DepthInterval depth_interval(const Vec3& centre, double reach) {
  // t = 1 + 1 / z in front of the near plane (world z < -1); nearer is t = 0.
  const auto t = [](double z) { return z < -1.0 ? 1.0 + 1.0 / z : 0.0; };
  return {t(centre[2] + reach), t(centre[2] - reach)};
}

std::vector<float> object_sample_warp(const ModelConfig& c, const std::vector<Vec3>& centres,
                                      const std::vector<double>& radii) {
  if (centres.size() != radii.size()) throw Error("object_sample_warp: one radius per centre", kExitInternal);
  std::vector<DepthInterval> intervals;
  for (size_t k = 0; k < centres.size(); ++k)
    intervals.push_back(depth_interval(centres[k], kObjectSampleRadii * radii[k]));
  return sample_warp(intervals, static_cast<double>(c.object_samples) / c.samples);
}

}  // namespace nova

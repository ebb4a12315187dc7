#pragma once
// Samples where the objects are: ModelConfig::object_samples of each ray's samples crowd into
// the depth ranges that hold the rigid objects at the view's time, the rest stay evenly spread
// (sample_warp.hpp). Evenly spread samples put one or two across a small object (an object
// 0.5 units deep at depth 2.8 spans 0.06 of NDC's [0, 1], two of 32 strata), so its density
// has to fill whole strata along each training ray, a slab that a turning object then shows
// sideways as blur; crowded, the object gets the samples a sharp surface needs.
//
// An object's range: the depths within kObjectSampleRadii of its radius (kObjectRadiusName,
// from its masks) about where its motion puts its pivot at that time (the pivot, the mean of
// the trajectory's translations, sits where the frames' anchors are: on the object, whose
// centre lies up to a radius behind its visible surface).
//
// Forward-facing (NDC) scenes only: there a sample's fraction t of the ray is its world depth
// alone, t = 1 - near / depth (near plane 1), the same on every ray of any camera, so one warp
// serves a whole view, augmented object cameras included. Metric scenes spread every sample.
#include <vector>

#include "nova/model/field_graphs.hpp"
#include "nova/model/model_config.hpp"
#include "nova/sampling/rigid_motion.hpp"
#include "nova/sampling/sample_warp.hpp"

namespace nova {

// Each object's radius in world units ([K]), set from its masks when the joint phase starts
// (initial_motion) and never learned: what a view's samples crowd about.
inline const char* const kObjectRadiusName = "objects.radius";
inline constexpr double kObjectSampleRadii = 2.0;

// Whether a model of `objects` rigid objects crowds samples about them on this scene.
bool uses_object_samples(const ModelConfig& c, const RayGeometry& geo, int objects);

// The fractions of the NDC sample range within `reach` world units in depth of the world
// point `centre` (empty for a range wholly in front of the near plane).
DepthInterval depth_interval(const Vec3& centre, double reach);

// The warp of a view whose objects' pivots stand at `centres` (world) with `radii`:
// c.object_samples / c.samples of the samples shared evenly by their ranges.
std::vector<float> object_sample_warp(const ModelConfig& c, const std::vector<Vec3>& centres,
                                      const std::vector<double>& radii);

}  // namespace nova

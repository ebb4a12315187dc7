#pragma once
// Samples where the objects are: ModelConfig::object_samples of each ray's samples crowd into
// the depth ranges of the rigid objects' boxes (FieldConfig::object_box) at the view's time,
// the rest stay evenly spread (sample_warp.hpp). Evenly spread samples put one or two across a
// small object (a box 0.4 units deep at depth 3 spans 0.05 of NDC's [0, 1], under two of 32
// strata), so its density has to fill a whole stratum along each training ray; in its box the
// object gets the samples a sharp surface needs.
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

// Whether a model of `objects` object NeRFs crowds samples into their boxes on this scene.
bool uses_object_samples(const ModelConfig& c, const RayGeometry& geo, int objects);

// The fractions of the NDC sample range that hold an object's box: box_row is its
// box_coordinates row (centre and log scale in canonical NDC, object_box_row),
// world_to_canonical the map from the view's world to its canonical space (motion_matrix at
// the view's time, composed with an instance's placement). The box's eight corners bound it
// (NDC and its inverse keep straight lines, a rigid map keeps them too). A box that reaches
// NDC's far end (a corner at infinite depth) reaches t = 1.
DepthInterval box_depth_interval(const float* box_row, const Mat34& world_to_canonical, const RayGeometry& geo);

// The warp of a view whose objects' boxes are `box_rows` (one pointer to 6 floats each) seen
// through `world_to_canonical` (one map each): c.object_samples / c.samples of the samples
// shared evenly by the boxes' intervals.
std::vector<float> object_sample_warp(const ModelConfig& c, const RayGeometry& geo,
                                      const std::vector<const float*>& box_rows,
                                      const std::vector<Mat34>& world_to_canonical);

}  // namespace nova

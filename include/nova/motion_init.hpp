#pragma once
// The starting trajectories of rigid objects (motion.hpp), from the scene's masks and
// disparity and the pretrained static NeRF.
#include <vector>

#include "nova/executor.hpp"
#include "nova/nova_fields.hpp"
#include "nova/nova_graphs.hpp"
#include "nova/runtime.hpp"
#include "nova/scene.hpp"

namespace nova {

// The [K, F, 6] motion rows (motion_parameter's layout): per object and frame no turn and
// a translation to its anchor, the mask's centroid at the object's depth (from the disparity
// fitted to the static NeRF's depth on background pixels, or without disparity or a fit the nearer
// quartile of the static depth behind the mask); frames where the object is not seen take
// their neighbours' anchors; so y = x - anchor(t) + mean anchor.
// `trained` holds the static NeRF's weights ("static.*").
std::vector<float> initial_motion(Runtime& rt, const Scene& scene, const RayGeometry& geo, const FieldConfig& field,
                                  int samples, Executor& trained);

}  // namespace nova

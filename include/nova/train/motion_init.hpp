#pragma once
// The starting trajectories of rigid objects (motion.hpp), from the scene's masks and
// disparity and the pretrained static NeRF.
#include <vector>

#include "nova/graph/executor.hpp"
#include "nova/model/fields.hpp"
#include "nova/model/field_graphs.hpp"
#include "nova/runtime/runtime.hpp"
#include "nova/model/scene.hpp"

namespace nova {

// The [K, F, 6] motion rows (motion_parameter's layout). With a disparity that the background's
// parallax places in depth (disparity_fit.hpp): per object, the first frame that shows it puts
// its canonical space at the mask's centroid at the median depth, unturned, and each later
// frame is the previous one moved by the alignment of the two frames' views of the object
// (motion_alignment.hpp). Otherwise no turn, and each frame's anchor is the mask's centroid at
// the nearer quartile of the static NeRF's depth behind the mask. Frames without the object
// take their neighbours' rows (linear between, the nearest beyond).
// `trained` holds the static NeRF's weights ("static.*"), rendered only without a fit.
std::vector<float> initial_motion(Runtime& rt, const Scene& scene, const RayGeometry& geo, const FieldConfig& field,
                                  int samples, Executor& trained);

}  // namespace nova

#pragma once
// The starting trajectories of rigid objects (motion.hpp), from the scene's masks and
// disparity and the pretrained static NeRF.
#include <array>
#include <vector>

#include "nova/graph/executor.hpp"
#include "nova/model/fields.hpp"
#include "nova/model/field_graphs.hpp"
#include "nova/runtime/runtime.hpp"
#include "nova/model/scene.hpp"
#include "nova/sampling/rigid_motion.hpp"
#include "nova/train/disparity_fit.hpp"
#include "nova/train/motion_alignment.hpp"

namespace nova {

// One frame's motion row: the Euler angles (x, y, z) and the translation (motion_parameter's).
using MotionRow = std::array<double, 6>;

// The rows of all `frames` frames from those of the frames `known` (ascending, one row each):
// linear between two known frames; before the first and after the last the translation keeps
// the speed of the nearest two known frames and the angles stay (one known frame: its row).
std::vector<MotionRow> fill_motion_rows(const std::vector<int>& known, const std::vector<MotionRow>& rows, int frames);

// The [K, F, 6] motion rows (motion_parameter's layout). With a disparity that the background's
// parallax places in depth (disparity_fit.hpp): per object, the first frame that shows it puts
// its canonical space at the mask's centroid at the median depth, unturned, and each later
// frame is the previous one moved by the alignment of the two frames' views of the object
// (motion_alignment.hpp). Otherwise no turn, and each frame's anchor is the mask's centroid at
// the nearer quartile of the static NeRF's depth behind the mask. Frames without the object
// take their neighbours' rows (fill_motion_rows).
// `trained` holds the static NeRF's weights ("static.*"), rendered only without a fit.
struct MotionStart {
  std::vector<float> rows;   // [K, F, 6]
  std::vector<float> boxes;  // [K, 6]: each object's box (FieldConfig::object_box), object_box_row
  std::vector<float> radii;  // [K]: each object's radius in world units (kObjectRadiusName)
};
// `fit`: the scene's fit_disparity when the caller has it already (null: computed here).
// `align`: how the frames' views are aligned (motion_alignment.hpp).
MotionStart initial_motion(Runtime& rt, const Scene& scene, const RayGeometry& geo, const FieldConfig& field,
                           int samples, Executor& trained, const DisparityFit* fit = nullptr,
                           const AlignmentOptions& align = {});

// The box_coordinates row (c, l) of a cube of half-size `half` (world units) about the world
// point `centre`: the box about the centre's image that holds the cube's image (in NDC the
// cube's near side stretches more: its reach is taken on both sides), no larger on any axis
// than the scene's box (RayGeometry::box; a metric scene's extent).
std::array<float, 6> object_box_row(const Vec3& centre, double half, const RayGeometry& geo);

// One object's box for its trajectory `rows` ([frames, 6]) and radius (world units): the cube
// of half-size kObjectBoxRadii radii about the rows' pivot (motion_pivot), where the canonical
// field finds the object. Whoever replaces a start's rows places the boxes again with it.
std::array<float, 6> object_box_for(const float* rows, int frames, double radius, const RayGeometry& geo);

// An object's radius in world units as one frame's mask shows it: the 95th percentile of its
// pixels' distances from their centroid, at the anchor's distance from the camera. 0 for an
// empty mask.
double mask_radius(const Image8& mask, const Camera& camera, const Vec3& anchor);

// The anchors (an object's mask centroid at its median depth) of the frames `frames`
// (ascending) that lie off the object's path: each pass drops the one farthest from where its neighbours
// put it (between the two around it, or beyond the nearest two at an end) while that distance
// is more than kOutlierSteps times the median step between consecutive anchors and more than
// `floor` (world units). Returns their indices, ascending; fewer than four anchors keep all.
inline constexpr double kOutlierSteps = 4.0;
std::vector<size_t> outlier_anchors(const std::vector<Vec3>& anchors, const std::vector<int>& frames, double floor);

// The frames the rigid start leaves out (initial_motion, and nova-bench motion to score the same
// start): outlier_anchors with a floor of kOutlierRadii times the median of the frames' object
// radii (mask_radius, one per anchor), so that a jump within the object's own size stays.
inline constexpr double kOutlierRadii = 2.0;
std::vector<size_t> off_path_anchors(const std::vector<Vec3>& anchors, const std::vector<int>& frames,
                                     const std::vector<double>& radii);

// Half-sizes of an object's box in units of its radius as the masks show it (the 95th
// percentile of its pixels' distances from their centroid, at the anchor's distance, the
// largest over the frames). The anchor sits on the object's visible surface, so its centre
// lies up to a radius behind; one more radius is the margin for what the masks miss.
inline constexpr double kObjectBoxRadii = 2.5;

}  // namespace nova

#pragma once
// The turn of a thin object (a rod, a stick, a pole) from its silhouettes alone. Such an
// object has too few interior pixels for align_object's colour-and-depth alignment, which
// then leaves it unturned, and its canonical shape becomes a fan of every frame's
// orientation. Its mask still shows where it points: the mask's principal axis gives the
// axis's direction in the image, and its length against the longest unclipped view gives the
// tilt out of the image plane (a rod seen end-on looks short). The tilt's sign cannot be
// seen; it is chosen for a steady spin (the candidate nearest the turn of the last two
// views carried on). Needs no flow, only the masks and each view's anchor.
#include <optional>
#include <vector>

#include "nova/train/motion_alignment.hpp"

namespace nova {

// One view's silhouette, measured at the object's anchor (a world point at its depth).
struct SilhouetteAxis {
  bool elongated = false;  // principal variances at least kElongation apart
  bool clipped = false;    // the mask touches the image's border: its length is not the object's
  Vec3 in_plane{0, 0, 0};  // unit world direction of the mask's principal axis at the anchor
  Vec3 toward{0, 0, 0};    // unit world direction from the anchor to the camera
  double length = 0;       // the principal axis's length (a uniform segment's), world units at the anchor
};

// A length at least 3 times the width (variance ratio 9): a box seen from a side, a disc seen
// edge-on for a frame, or a blob of a few pixels is not taken for a rod.
inline constexpr double kElongation = 9.0;

SilhouetteAxis silhouette_axis(const ObjectView& view, const Vec3& anchor);

// The object's axis (unit world vector) in every view whose mask is elongated, chained for
// continuity (an axis and its opposite are the same rod); nullopt elsewhere.
std::vector<std::optional<Vec3>> silhouette_axes(const std::vector<ObjectView>& views, const std::vector<Vec3>& anchors);

// The rigid map (world -> world) that turns `from` onto `to` by the smallest rotation about
// `pivot` and then moves `pivot` to `destination`.
Mat34 turn_onto(const Vec3& from, const Vec3& to, const Vec3& pivot, const Vec3& destination);

}  // namespace nova

#pragma once
// The rigid motion of one object between two frames of the video, from the frames alone:
// the first frame's view of the object (its masked pixels, placed in the scene at their
// depth) is moved until it matches the second frame's colours, mask and depth. This is how
// a rigid object's turn is found before training (a trajectory learned from no turn at all
// does not find a turn of tens of degrees through the hash grid's local gradients); it needs
// no optical flow, only what nova is given.
#include <vector>

#include "nova/sampling/rigid_motion.hpp"
#include "nova/model/scene.hpp"

namespace nova {

// One frame's view of one object. Depth is the camera-space depth (distance along the
// view axis, camera.hpp's -z) of every pixel, <= 0 or not finite where unknown.
struct ObjectView {
  const Camera* camera = nullptr;
  const Image8* rgb = nullptr;
  const Image8* mask = nullptr;  // the object's mask (>= 128 inside)
  const ImageF* depth = nullptr;
};

struct AlignmentOptions {
  // Coarse to fine: the images are blurred by each sigma (pixels, at 160 px width; scaled
  // with the image) in turn, so that the first levels see a turn of several pixels.
  std::vector<double> blur_px{2.0, 1.0, 0.5};
  int iterations = 10;          // Gauss-Newton steps per level
  int max_points = 1200;        // of the first view's pixels
  // Pixels of each mask's rim left out (at least 1), where a blurred disparity mixes the
  // object's depth with the background's. A 2-pixel rim follows the family's turns better
  // and trains worse objects (docs/accuracy-studies.md): 1.
  int edge_px = 1;
  double depth_weight = 1.0;    // a relative depth error of 10 % weighs as a colour error of 0.1
  double mask_weight = 0.5;     // a point outside the second mask weighs as a colour error of 0.5
  double turn_prior = 1e-3;     // damping towards no turn (per radian squared), for textureless objects
  int window = 1;               // track_object: earlier views aligned at once to each next one
  // track_object: each mask pixel's depth becomes the nearest of the mask's depths within this
  // many pixels (at 160 px width, scaled with the image; 0: as given). A disparity blurred over
  // the silhouette reads the object's rim part way to the background behind it, which flattens
  // the object and makes the alignment under-turn; the object lies in front of what it is
  // blurred with, so the nearest depth close by undoes most of the mixing.
  double depth_reach_px = 0.0;
  // track_object, window 1: each pair's turn is checked by aligning the second view back to
  // the first; where the two turns fail to undo each other by more than this fraction of the
  // turn (and more than consistency_floor_deg), the pair takes no turn, the anchors' shift
  // alone (0: no check).
  double consistency = 0.0;
  double consistency_floor_deg = 3.0;
  // track_object, window 1: a pair with too few interior points to align (a rod a few pixels
  // wide) turns as its masks' principal axes do (silhouette_axis.hpp) instead of not at all.
  // Off: on the family's thin rod it follows the axis and trains worse inside the object
  // (docs/accuracy-studies.md, "Thin objects' turns from their silhouettes").
  bool silhouette_turns = false;
  // track_object, window 1: a pair whose alignment ends with a mean residual above this many
  // times the median of the object's aligned pairs, or that has too few interior points to
  // align, takes the turn of the nearest reliable pairs before and after it (interpolated in
  // axis-angle) and the translation that aligns it best under that turn (the anchors' shift
  // where it has too few points). A spin seldom changes its rate within a frame, and a pair
  // that aligns badly (a symmetric object settling in another of its looks) is more often
  // wrong than the spin is irregular. Pairs at either end of the video, with a reliable pair
  // on one side only, keep their own: there the object enters or leaves the view, cut by the
  // border, and a turn carried on from the inner pairs trained worse objects than the pair's
  // own (docs/accuracy-studies.md). On the family's dev objects the pairs within 6 degrees of
  // the true turn end at most 1.9 times the median (one 4.2) and 14 of the 25 pairs further
  // off at 6 to 59 times (the rest, 6-9 degrees off under a blurred disparity, end as the
  // good ones do). 0: off.
  double bridge_ratio = 0.0;
};

// Fewer interior points than this give align_object no turn: the anchors' shift alone.
inline constexpr int kMinAlignmentPoints = 8;

// Whether an alignment of view a to view b (`forward`) and one of b back to a (`backward`)
// undo each other's turn: the turn left after both, within options.consistency of the forward
// turn or options.consistency_floor_deg. A symmetric object (a dumbbell, a disc) looks the same
// at several turns, and each direction can settle in a turn of its own; on the family's
// spinning dumbbells such a turn is wronger than no turn at all, which a pair that fails this
// check takes in track_object (the anchors' shift alone).
bool turns_agree(const Mat34& forward, const Mat34& backward, const AlignmentOptions& options);

// Each pixel of `mask` (>= 128) takes the smallest valid depth (> 0, finite) of the mask's
// pixels in the square of half-width `reach` about it; other pixels, and mask pixels with no
// valid depth in their square, keep theirs.
ImageF nearest_depth_within(const ImageF& depth, const Image8& mask, int reach);

struct ObjectAlignment {
  Mat34 motion{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};  // world -> world, view a's object to view b's
  double turn = 0;                                   // its rotation angle (radians)
  int points = 0;                                    // of view a that were aligned
  double residual = 0;                               // mean squared residual at the end
};

// Aligns view a's object to view b. The motion turns about the centroid of a's points and then
// translates; `translation` is the starting translation (e.g. the shift of the masks' anchors).
ObjectAlignment align_object(const ObjectView& a, const ObjectView& b, const Vec3& translation,
                             const AlignmentOptions& options = {});

// One view of the object with the rigid map (world -> world) that moves its points to where
// the object stood in the reference view, the one the motion starts from.
struct PlacedView {
  ObjectView view;
  Mat34 to_reference{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
};

// The same with several views of the object at once, the first the reference: each view's
// points are placed in the reference by its map and all of them are moved together, so a
// view further back (a larger turn away) also constrains the turn.
ObjectAlignment align_object(const std::vector<PlacedView>& a, const ObjectView& b, const Vec3& translation,
                             const AlignmentOptions& options = {});

// The object's pose (object -> world) in every view of a video, the first at anchors[0]
// unturned: each next view is aligned to the last `options.window` views placed by their
// poses, starting from the shift between the two latest anchors (e.g. the masks' centroids
// at their depth).
std::vector<Mat34> track_object(const std::vector<ObjectView>& views, const std::vector<Vec3>& anchors,
                                const AlignmentOptions& options = {});

}  // namespace nova

// align_object (motion_alignment.hpp) against the synthetic world's exact object poses, and
// the Euler angles' round trip and continuity.
#include <boost/test/unit_test.hpp>
#include <atomic>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "nova/data/llff_poses.hpp"
#include "nova/data/synth.hpp"
#include "nova/train/disparity_edges.hpp"
#include "nova/train/motion_alignment.hpp"
#include "nova/train/silhouette_axis.hpp"
#include "scene_test_util.hpp"
#include "train/parallel_for.hpp"

using namespace nova;

namespace {

constexpr double kDegree = 3.14159265358979323846 / 180.0;

// Angle of the rotation a b^T (radians).
double angle_between(const Mat3& a, const Mat3& b) {
  double trace = 0;
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) trace += a[static_cast<size_t>(i * 3 + k)] * b[static_cast<size_t>(i * 3 + k)];
  return std::acos(std::clamp((trace - 1) / 2, -1.0, 1.0));
}

Mat3 rotation_of(const Pose34& p) {
  return {p[0], p[1], p[2], p[4], p[5], p[6], p[8], p[9], p[10]};
}

}  // namespace

BOOST_AUTO_TEST_SUITE(motion_alignment)

// Each object of the default synthetic scene between frames 0 -> 1 and 10 -> 11, from the
// renders' exact colours, masks and depth, starting 0.07 off the true translation: the found
// turn against the world's (6.0 degrees a frame for the box, 7.2 for the sphere). Measured:
// the box within 0.5 degrees and 0.006 of its centre, the striped sphere (whose turn only its
// texture shows; at frame 10 the box passes in front of it) within 1.7 degrees and 0.018
// (radius 0.42). Bounds 3.5 degrees and 0.04: twice the worst, for other compilers' and
// libm's rounding along the same Gauss-Newton path.
BOOST_AUTO_TEST_CASE(finds_the_synthetic_objects_turns) {
  const SynthWorld w("default", 0);
  const int F = w.preset().frames;
  for (int first : {0, 10}) {
    const double t0 = frame_time(first, F), t1 = frame_time(first + 1, F);
    const Camera c0 = w.camera(first), c1 = w.camera(first + 1);
    const SynthRender r0 = w.render(c0, t0), r1 = w.render(c1, t1);
    for (int k = 1; k <= w.objects(); ++k) {
      const Pose34 p0 = w.object_pose(k, t0), p1 = w.object_pose(k, t1);
      const ObjectView a{&c0, &r0.rgb, &r0.masks[static_cast<size_t>(k)], &r0.depth};
      const ObjectView b{&c1, &r1.rgb, &r1.masks[static_cast<size_t>(k)], &r1.depth};
      // The starting translation as the masks give it: the true one, off by 0.05.
      const Vec3 guess{p1[3] - p0[3] + 0.05, p1[7] - p0[7], p1[11] - p0[11] - 0.05};
      const ObjectAlignment al = align_object(a, b, guess);
      BOOST_TEST_INFO("object " << k << " frames " << first << " -> " << first + 1);
      BOOST_TEST(al.points > 100);
      // The true turn is R1 R0^T; the found one the motion's rotation.
      const Mat3 r0m = rotation_of(p0), r1m = rotation_of(p1);
      Mat3 truth{};
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
          for (int l = 0; l < 3; ++l)
            truth[static_cast<size_t>(i * 3 + j)] += r1m[static_cast<size_t>(i * 3 + l)] * r0m[static_cast<size_t>(j * 3 + l)];
      const Mat3 found = rotation_of(al.motion);
      const double error = angle_between(found, truth);
      const Vec3 centre = apply_rigid(al.motion, {p0[3], p0[7], p0[11]});
      const double miss = std::hypot(centre[0] - p1[3], centre[1] - p1[7], centre[2] - p1[11]);
      BOOST_TEST_MESSAGE("object " << k << " from frame " << first << ": turn off by " << error / kDegree
                                   << " degrees, centre by " << miss);
      BOOST_TEST(error < 3.5 * kDegree);
      BOOST_TEST(miss < 0.04);
    }
  }
}

// Without texture, mask or depth change to follow, nothing moves: two identical views align
// to the identity.
BOOST_AUTO_TEST_CASE(identical_views_do_not_move) {
  const SynthWorld w("default", 3);
  const Camera c = w.camera(0);
  const SynthRender r = w.render(c, -1.0);
  const ObjectView a{&c, &r.rgb, &r.masks[1], &r.depth};
  const ObjectAlignment al = align_object(a, a, {0, 0, 0});
  BOOST_TEST(al.turn < 1e-6);
  for (int k : {3, 7, 11}) BOOST_TEST(std::fabs(al.motion[static_cast<size_t>(k)]) < 1e-6);
}

// The rim of each mask is left out by edge_px: a wider margin keeps fewer pixels, and a mask
// too thin to keep any gives no turn, only the starting translation.
BOOST_AUTO_TEST_CASE(the_masks_rim_is_left_out) {
  const SynthWorld w("default", 3);
  const Camera c = w.camera(0);
  const SynthRender r = w.render(c, -1.0);
  int last = 1 << 30;
  for (int edge : {1, 2, 4}) {
    AlignmentOptions o;
    o.edge_px = edge;
    o.max_points = 1 << 20;    // every interior pixel, none skipped
    const ObjectAlignment al = align_object({&c, &r.rgb, &r.masks[1], &r.depth}, {&c, &r.rgb, &r.masks[1], &r.depth},
                                            {0, 0, 0}, o);
    BOOST_TEST_MESSAGE("rim " << edge << " px: " << al.points << " points");
    BOOST_TEST(al.points > 0);
    BOOST_TEST(al.points < last);
    last = al.points;
  }
  // A mask two pixels wide: nothing is three pixels inside it.
  Image8 thin = r.masks[1];
  std::fill(thin.data.begin(), thin.data.end(), uint8_t{0});
  for (int y = 10; y < thin.height - 10; ++y)
    for (int x = thin.width / 2; x < thin.width / 2 + 2; ++x) thin.at(x, y) = 255;
  AlignmentOptions o;
  o.edge_px = 3;
  const Vec3 shift{0.01, -0.02, 0.03};
  const ObjectAlignment al = align_object({&c, &r.rgb, &thin, &r.depth}, {&c, &r.rgb, &thin, &r.depth}, shift, o);
  BOOST_TEST(al.points == 0);
  BOOST_TEST(al.turn == 0.0);
  for (int k = 0; k < 3; ++k) BOOST_TEST(al.motion[static_cast<size_t>(k * 4 + 3)] == shift[static_cast<size_t>(k)]);
}

namespace {

// The rotation R1 R0^T of a move from pose p0 to pose p1 (object -> world).
Mat3 turn_between(const Pose34& p0, const Pose34& p1) {
  const Mat3 r0 = rotation_of(p0), r1 = rotation_of(p1);
  Mat3 t{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int l = 0; l < 3; ++l) t[static_cast<size_t>(i * 3 + j)] += r1[static_cast<size_t>(i * 3 + l)] * r0[static_cast<size_t>(j * 3 + l)];
  return t;
}

// Frames first.. first + count - 1 of a synthetic scene (the default one unless named),
// rendered with exact depth.
struct Video {
  const SynthWorld world;
  std::vector<Camera> cameras;
  std::vector<SynthRender> renders;
  std::vector<double> times;
  Video(int first, int count, const std::string& preset = "default", uint32_t seed = 0) : world(preset, seed) {
    const int F = world.preset().frames;
    for (int i = first; i < first + count; ++i) {
      times.push_back(frame_time(i, F));
      cameras.push_back(world.camera(i));
      renders.push_back(world.render(cameras.back(), times.back()));
    }
  }
  std::vector<ObjectView> views(int k) const {
    std::vector<ObjectView> v;
    for (size_t i = 0; i < renders.size(); ++i)
      v.push_back({&cameras[i], &renders[i].rgb, &renders[i].masks[static_cast<size_t>(k)], &renders[i].depth});
    return v;
  }
  // The object's centre in every frame, off by 0.03 (as the masks' anchors would be).
  std::vector<Vec3> anchors(int k) const {
    std::vector<Vec3> a;
    for (double t : times) {
      const Pose34 p = world.object_pose(k, t);
      a.push_back({p[3] + 0.03, p[7] - 0.03, p[11]});
    }
    return a;
  }
};

}  // namespace

// With one view back, tracking is the frame pairs' alignments chained: the same poses, bit
// for bit, with the depths as given and no check of the turns; with the turns checked, the
// default scene's textured sphere and box pass every check, and the poses stay the same.
BOOST_AUTO_TEST_CASE(tracking_one_view_back_chains_the_pairs) {
  const Video video(0, 4);
  for (int k = 1; k <= video.world.objects(); ++k) {
    const std::vector<ObjectView> views = video.views(k);
    const std::vector<Vec3> anchors = video.anchors(k);
    AlignmentOptions plain;
    plain.depth_reach_px = 0;
    plain.consistency = 0;
    AlignmentOptions checked = plain;
    checked.consistency = 1.0;
    const std::vector<Mat34> poses = track_object(views, anchors, plain), checked_poses = track_object(views, anchors, checked);
    BOOST_TEST_REQUIRE(poses.size() == views.size());
    Mat34 pose{1, 0, 0, anchors[0][0], 0, 1, 0, anchors[0][1], 0, 0, 1, anchors[0][2]};
    for (size_t j = 0; j < views.size(); ++j) {
      if (j > 0) {
        const Vec3 shift{anchors[j][0] - anchors[j - 1][0], anchors[j][1] - anchors[j - 1][1], anchors[j][2] - anchors[j - 1][2]};
        pose = compose_rigid(align_object(views[j - 1], views[j], shift, plain).motion, pose);
      }
      for (size_t e = 0; e < 12; ++e) {
        BOOST_TEST(poses[j][e] == pose[e]);
        BOOST_TEST(checked_poses[j][e] == pose[e], "object " << k << ", view " << j << ": a pair failed the turn check");
      }
    }
  }
}

// turns_agree: a turn and its inverse agree; a turn found the same way in both directions
// (what a symmetric object can give) does not, unless both are within the floor.
BOOST_AUTO_TEST_CASE(turns_agree_when_the_way_back_undoes_the_turn) {
  const auto turn_y = [](double degrees) {
    const double a = degrees * kDegree;
    return Mat34{std::cos(a), 0, std::sin(a), 0.1, 0, 1, 0, -0.2, -std::sin(a), 0, std::cos(a), 0.3};
  };
  AlignmentOptions o;
  o.consistency = 1.0;  // and the floor's 3 degrees
  BOOST_TEST(turns_agree(turn_y(30), invert_rigid(turn_y(30)), o));
  BOOST_TEST(turns_agree(turn_y(30), turn_y(-20), o));   // 10 degrees left over of 30
  BOOST_TEST(!turns_agree(turn_y(30), turn_y(15), o));   // 45 left over
  BOOST_TEST(!turns_agree(turn_y(2), turn_y(2), o));     // 4 left over: above the floor and the turn
  BOOST_TEST(turns_agree(turn_y(1), turn_y(1), o));      // 2 left over: within the floor
  o.consistency = 0.2;
  BOOST_TEST(!turns_agree(turn_y(30), turn_y(-20), o));  // 10 > 0.2 x 30

  // A check no pair passes (no gap allowed): every pair takes the anchors' shift alone, so
  // each pose is its anchor, unturned.
  const Video video(0, 3);
  AlignmentOptions strict;
  strict.consistency = 1e-12;
  strict.consistency_floor_deg = 0;
  const std::vector<Vec3> anchors = video.anchors(1);
  const std::vector<Mat34> poses = track_object(video.views(1), anchors, strict);
  BOOST_TEST_REQUIRE(poses.size() == anchors.size());
  for (size_t j = 0; j < poses.size(); ++j) {
    const Mat34 want{1, 0, 0, anchors[j][0], 0, 1, 0, anchors[j][1], 0, 0, 1, anchors[j][2]};
    for (size_t e = 0; e < 12; ++e) BOOST_TEST(std::fabs(poses[j][e] - want[e]) < 1e-12, "view " << j << " element " << e);
  }
}

// Several views aligned at once to the next frame: frame 2 of the default scene against frame
// 1 and frame 0 placed where the object stood in frame 1 (by the true move). Measured: the
// striped sphere 2.7 degrees off the true turn and 0.014 off its centre, the box 0.26 and
// 0.0007; bounds as the two-view test's (about twice the worst, for other compilers' rounding
// along the same Levenberg-Marquardt path).
BOOST_AUTO_TEST_CASE(placed_views_align_together) {
  const Video video(0, 3);
  for (int k = 1; k <= video.world.objects(); ++k) {
    const std::vector<ObjectView> views = video.views(k);
    const Pose34 p0 = video.world.object_pose(k, video.times[0]), p1 = video.world.object_pose(k, video.times[1]),
                 p2 = video.world.object_pose(k, video.times[2]);
    // Frame 0's world -> frame 1's world: p1 p0^-1 (a pose is a rigid 3 x 4 map).
    const std::vector<PlacedView> earlier{{views[1], {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0}},
                                          {views[0], compose_rigid(p1, invert_rigid(p0))}};
    const Vec3 guess{p2[3] - p1[3] + 0.05, p2[7] - p1[7], p2[11] - p1[11] - 0.05};
    const ObjectAlignment al = align_object(earlier, views[2], guess);
    const double error = angle_between(rotation_of(al.motion), turn_between(p1, p2));
    const Vec3 centre = apply_rigid(al.motion, {p1[3], p1[7], p1[11]});
    const double miss = std::hypot(centre[0] - p2[3], centre[1] - p2[7], centre[2] - p2[11]);
    BOOST_TEST_MESSAGE("object " << k << " from frames 0, 1 to 2: turn off by " << error / kDegree
                                 << " degrees, centre by " << miss << ", " << al.points << " points");
    BOOST_TEST(al.points > 200);
    BOOST_TEST(error < 3.5 * kDegree);
    BOOST_TEST(miss < 0.04);
  }
}

// Tracking three views back along the default scene's first 8 frames: the chained turn's
// drift by the last frame against the world's (50 and 42 degrees of turn). Measured: the
// sphere 6.3 degrees, the box 0.48 (one view back: 4.7 and 0.67); bound 12, twice the worst.
BOOST_AUTO_TEST_CASE(tracking_several_views_back_keeps_the_turn) {
  const Video video(0, 8);
  for (int k = 1; k <= video.world.objects(); ++k) {
    AlignmentOptions options;
    options.window = 3;
    const std::vector<Mat34> poses = track_object(video.views(k), video.anchors(k), options);
    const Pose34 first = video.world.object_pose(k, video.times.front()), last = video.world.object_pose(k, video.times.back());
    const double drift = angle_between(turn_between(poses.front(), poses.back()), turn_between(first, last));
    BOOST_TEST_MESSAGE("object " << k << ": drift by frame 7 " << drift / kDegree << " degrees of "
                                 << angle_between(turn_between(first, last), {1, 0, 0, 0, 1, 0, 0, 0, 1}) / kDegree);
    BOOST_TEST(drift < 12 * kDegree);
  }
}

// Euler angles: the matrix of the angles found is the matrix given (both solutions and any
// 2 pi shift describe it), and the one nearest `near` is taken, so a spin stays continuous.
BOOST_AUTO_TEST_CASE(euler_angles_round_trip_and_stay_near) {
  const Vec3 cases[] = {{0.3, -0.2, 1.1}, {2.9, 1.4, -3.0}, {-1.0, -1.5, 0.2}};
  for (const Vec3& angles : cases) {
    const Mat3 m = euler_xyz_to_matrix(angles);
    for (const Vec3& near : {Vec3{0, 0, 0}, angles, Vec3{angles[0] + 6.0, angles[1], angles[2] - 6.5}}) {
      const Vec3 e = matrix_to_euler_xyz(m, near);
      const Mat3 back = euler_xyz_to_matrix(e);
      for (size_t i = 0; i < 9; ++i) BOOST_TEST(std::fabs(back[i] - m[i]) < 1e-12);
    }
    // Given the angles themselves as `near`, they come back (within float64 rounding).
    const Vec3 e = matrix_to_euler_xyz(m, angles);
    for (int k = 0; k < 3; ++k) BOOST_TEST(std::fabs(e[static_cast<size_t>(k)] - angles[static_cast<size_t>(k)]) < 1e-9);
  }
  // A turn about y past 90 degrees continues from its neighbour instead of flipping.
  Vec3 previous{0, 0, 0};
  for (int step = 1; step <= 40; ++step) {
    const Vec3 e = matrix_to_euler_xyz(euler_xyz_to_matrix({0, 0.1 * step, 0}), previous);
    BOOST_TEST(std::fabs(e[1] - previous[1]) + std::fabs(e[0] - previous[0]) + std::fabs(e[2] - previous[2]) < 0.1 + 1e-9);
    previous = e;
  }
}

// Axis-angle from a matrix: the rotation of the vector found is the matrix given, and a vector
// with |w| < pi comes back itself; at pi (where w and -w are one rotation) either does.
BOOST_AUTO_TEST_CASE(axis_angle_round_trips) {
  const double pi = 3.14159265358979323846;
  const Vec3 cases[] = {{0, 0, 0}, {1e-7, -2e-7, 0}, {0.3, -0.2, 1.1}, {-2.0, 1.5, 0.4}, {0, pi, 0},
                        {pi / std::sqrt(2.0), 0, -pi / std::sqrt(2.0)}, {0, 0, pi - 1e-6}, {0.5, 0.5, 0.5}};
  for (const Vec3& w : cases) {
    const Mat3 m = axis_angle_to_matrix(w);
    const Vec3 back = matrix_to_axis_angle(m);
    const Mat3 again = axis_angle_to_matrix(back);
    BOOST_TEST_INFO("w = (" << w[0] << ", " << w[1] << ", " << w[2] << ")");
    for (size_t i = 0; i < 9; ++i) BOOST_TEST(std::fabs(again[i] - m[i]) < 1e-9);
    if (std::hypot(w[0], w[1], w[2]) < pi - 1e-3)
      for (size_t k = 0; k < 3; ++k) BOOST_TEST(std::fabs(back[k] - w[k]) < 1e-9);
  }
}

// A frame pair that aligns badly takes its neighbours' turn (AlignmentOptions::bridge_ratio):
// the box of the default scene (6 degrees a frame about one axis) over eight frames, with the
// colours inside the box's mask mirrored left to right in frames 3 and 7, so that pairs 2 -> 3,
// 3 -> 4 and 6 -> 7 align to wrong turns with residuals far above the four good pairs'.
// Bridged, the two inner pairs take the turn of pairs 1 -> 2 and 4 -> 5 and a translation
// aligned under it; the last pair, with a reliable pair on one side only, and the good pairs
// keep theirs. Measured: the inner spoilt pairs' turns off by 16.6 and 9.5 degrees as
// aligned, 0.14 and 0.29 bridged (the neighbours' own errors are 0.10 and 0.44); their moves
// carry the box's centre 0.056 and 0.021 off as aligned, 0.034 and 0.020 bridged; the last
// pair leaves 104 times the median pair's residual. Bounds: 2
// degrees, four times the neighbours' worst, as the other cases here allow for other
// compilers' rounding along the same Levenberg-Marquardt path; 0.05 for the centre, about
// the anchors' own 0.042 (its colours are still spoilt where the translation is aligned).
BOOST_AUTO_TEST_CASE(a_pair_that_aligns_badly_takes_its_neighbours_turn) {
  Video video(0, 8);
  const int k = 2;  // the box
  auto at = [](const Image8& im, int x, int y, int c) -> size_t {
    return (static_cast<size_t>(y) * static_cast<size_t>(im.width) + static_cast<size_t>(x)) * static_cast<size_t>(im.channels) + static_cast<size_t>(c);
  };
  for (size_t frame : {3u, 7u}) {
    SynthRender& spoilt = video.renders[frame];
    const Image8& mask = spoilt.masks[static_cast<size_t>(k)];
    int x0 = mask.width, x1 = -1;
    for (int y = 0; y < mask.height; ++y)
      for (int x = 0; x < mask.width; ++x)
        if (mask.at(x, y) >= 128) x0 = std::min(x0, x), x1 = std::max(x1, x);
    const Image8 original = spoilt.rgb;
    for (int y = 0; y < mask.height; ++y)
      for (int x = x0; x <= x1; ++x)
        if (mask.at(x, y) >= 128 && mask.at(x0 + x1 - x, y) >= 128)
          for (int c = 0; c < original.channels; ++c) spoilt.rgb.data[at(spoilt.rgb, x, y, c)] = original.data[at(original, x0 + x1 - x, y, c)];
  }
  const std::vector<ObjectView> views = video.views(k);
  const std::vector<Vec3> anchors = video.anchors(k);
  AlignmentOptions plain, bridged;
  bridged.bridge_ratio = 4;
  const std::vector<Mat34> a = track_object(views, anchors, plain), b = track_object(views, anchors, bridged);
  BOOST_TEST_REQUIRE(a.size() == views.size());
  BOOST_TEST_REQUIRE(b.size() == views.size());
  for (size_t j = 1; j < views.size(); ++j) {
    const Mat3 truth = turn_between(video.world.object_pose(k, video.times[j - 1]), video.world.object_pose(k, video.times[j]));
    const double as_aligned = angle_between(turn_between(a[j - 1], a[j]), truth),
                 as_bridged = angle_between(turn_between(b[j - 1], b[j]), truth);
    BOOST_TEST_MESSAGE("pair " << j - 1 << " -> " << j << ": turn off by " << as_aligned / kDegree << " degrees aligned, "
                               << as_bridged / kDegree << " bridged");
    if (j == 3 || j == 4) {
      BOOST_TEST(as_aligned > 5 * kDegree, "pair " << j - 1 << " -> " << j << " was not spoilt");
      BOOST_TEST(as_bridged < 2 * kDegree);
    } else {
      if (j == 7) BOOST_TEST(as_aligned > 5 * kDegree, "the last pair was not spoilt");
      // Its own turn and move: the composed step is the same map.
      const Mat34 step_a = compose_rigid(a[j], invert_rigid(a[j - 1])), step_b = compose_rigid(b[j], invert_rigid(b[j - 1]));
      for (size_t e = 0; e < 12; ++e) BOOST_TEST(std::fabs(step_a[e] - step_b[e]) < 1e-12, "pair " << j - 1 << " element " << e);
    }
  }
  // The last pair is kept for its place alone: its residual is above the limit too.
  std::vector<double> residual;
  for (size_t j = 1; j < views.size(); ++j) {
    const Vec3 shift{anchors[j][0] - anchors[j - 1][0], anchors[j][1] - anchors[j - 1][1], anchors[j][2] - anchors[j - 1][2]};
    residual.push_back(align_object(views[j - 1], views[j], shift, plain).residual);
  }
  std::vector<double> sorted = residual;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
  BOOST_TEST_MESSAGE("the last pair's residual: " << residual.back() / sorted[sorted.size() / 2] << " times the median");
  BOOST_TEST(residual.back() > bridged.bridge_ratio * sorted[sorted.size() / 2]);
  // A bridged pair's translation is aligned under its new turn: where it carries the box's
  // centre against where the spoilt alignment did.
  for (size_t j : {3u, 4u}) {
    const Pose34 p0 = video.world.object_pose(k, video.times[j - 1]), p1 = video.world.object_pose(k, video.times[j]);
    auto miss = [&](const std::vector<Mat34>& poses) {
      const Vec3 moved = apply_rigid(compose_rigid(poses[j], invert_rigid(poses[j - 1])), {p0[3], p0[7], p0[11]});
      return std::hypot(moved[0] - p1[3], moved[1] - p1[7], moved[2] - p1[11]);
    };
    BOOST_TEST_MESSAGE("pair " << j - 1 << " -> " << j << ": centre off by " << miss(a) << " aligned, " << miss(b) << " bridged");
    BOOST_TEST(miss(b) < 0.05);
  }
}

// The host's parallel loop behind the tracks and the disparity fit: every index runs once
// (more indices than threads, and none), and an exception thrown by one index reaches the
// caller after every thread has stopped.
// nearest_depth_within against a brute-force reading: mask pixels take the smallest valid depth
// of the mask in their square, everything else keeps its depth.
BOOST_AUTO_TEST_CASE(nearest_depth_reads_the_masks_square) {
  const int W = 19, H = 13;
  ImageF depth{W, H, std::vector<float>(W * H)};
  Image8 mask(W, H, 1, 0);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      depth.data[static_cast<size_t>(y * W + x)] = 1.0f + 0.37f * static_cast<float>((x * 7 + y * 5) % 11);
      if ((x - 9) * (x - 9) + 2 * (y - 6) * (y - 6) < 40) mask.at(x, y) = 255;
    }
  depth.data[6 * W + 9] = -1.0f;                                      // invalid inside the mask
  depth.data[6 * W + 10] = std::numeric_limits<float>::quiet_NaN();  // likewise
  depth.data[0] = 0.01f;                                              // nearest of all, outside the mask
  for (int reach : {0, 1, 2, 4}) {
    const ImageF got = nearest_depth_within(depth, mask, reach);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const float own = depth.data[static_cast<size_t>(y * W + x)];
        float want = own;
        if (mask.at(x, y) >= 128) {
          float best = std::numeric_limits<float>::infinity();
          for (int yy = std::max(0, y - reach); yy <= std::min(H - 1, y + reach); ++yy)
            for (int xx = std::max(0, x - reach); xx <= std::min(W - 1, x + reach); ++xx) {
              const float z = depth.data[static_cast<size_t>(yy * W + xx)];
              if (mask.at(xx, yy) >= 128 && z > 0 && std::isfinite(z)) best = std::min(best, z);
            }
          if (std::isfinite(best)) want = best;
        }
        const float g = got.data[static_cast<size_t>(y * W + x)];
        BOOST_TEST((g == want || (std::isnan(g) && std::isnan(want))), "reach " << reach << " at " << x << "," << y << ": " << g << " want " << want);
      }
  }
  // Reach 0 leaves every valid depth as it is; the invalid ones stay invalid.
  const ImageF same = nearest_depth_within(depth, mask, 0);
  BOOST_TEST(same.data[6 * W + 9] == -1.0f);
  BOOST_TEST(same.data[0] == 0.01f);
}

BOOST_AUTO_TEST_CASE(parallel_for_runs_every_index_once_and_rethrows) {
  for (size_t n : {size_t{0}, size_t{1}, size_t{7}, size_t{1000}}) {
    std::vector<std::atomic<int>> runs(n);
    detail::parallel_for(n, [&](size_t i) { ++runs[i]; });
    for (size_t i = 0; i < n; ++i) BOOST_TEST(runs[i].load() == 1);
  }
  std::atomic<int> done{0};
  BOOST_CHECK_THROW(detail::parallel_for(100, [&](size_t i) {
                      if (i == 37) throw std::runtime_error("index 37");
                      ++done;
                    }),
                    std::runtime_error);
  BOOST_TEST(done.load() == 99);
}

// silhouette_step_share against a disc whose disparity steps at its edge (1), the same step
// box-blurred over 5 pixels (under kBlurredStepShare), a mask one pixel larger than the disc
// (its rim reads the background: about 0) and the cases with no value.
BOOST_AUTO_TEST_CASE(step_share_reads_where_the_disparity_steps) {
  const int W = 40, H = 30;
  const auto disc_scene = [&](double radius, double mask_radius, int blur) {
    Scene s;
    Frame f;
    f.masks.assign(2, Image8(W, H, 1));
    f.disparity.width = W, f.disparity.height = H;
    f.disparity.data.assign(static_cast<size_t>(W) * H, 0.0f);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const double r = std::hypot(x - 20.0, y - 15.0);
        f.disparity.data[static_cast<size_t>(y) * W + x] = r <= radius ? 2.0f : 0.5f;
        if (r <= mask_radius) f.masks[1].data[static_cast<size_t>(y) * W + x] = 255;
      }
    test::box_blur(f.disparity, blur);
    s.frames.assign(3, f);
    return s;
  };
  const std::optional<double> sharp = silhouette_step_share(disc_scene(8, 8, 0));
  BOOST_REQUIRE(sharp.has_value());
  BOOST_TEST(*sharp == 1.0, boost::test_tools::tolerance(1e-9));
  const std::optional<double> blurred = silhouette_step_share(disc_scene(8, 8, 2));
  BOOST_REQUIRE(blurred.has_value());
  // A 5-pixel box over a step of 1.5: the rim pixels read 0.32 of it above the pixels touching
  // the mask (a reading against the background further out, 0.64, would be wrong).
  BOOST_TEST(*blurred < kBlurredStepShare);
  BOOST_TEST(*blurred == 0.32, boost::test_tools::tolerance(0.05));
  const std::optional<double> wide_mask = silhouette_step_share(disc_scene(8, 9, 0));
  BOOST_REQUIRE(wide_mask.has_value());
  BOOST_TEST(std::abs(*wide_mask) < 0.05);
  // No disparity; a mask too thin for interior pixels (a 3-pixel bar); no object in front.
  Scene none = disc_scene(8, 8, 0);
  for (Frame& f : none.frames) f.disparity = ImageF{};
  BOOST_TEST(!silhouette_step_share(none).has_value());
  Scene thin = disc_scene(8, 8, 0);
  for (Frame& f : thin.frames)
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) f.masks[1].data[static_cast<size_t>(y) * W + x] = (y >= 14 && y <= 16) ? 255 : 0;
  BOOST_TEST(!silhouette_step_share(thin).has_value());
  Scene behind = disc_scene(8, 8, 0);
  for (Frame& f : behind.frames)
    for (float& v : f.disparity.data) v = 2.5f - v;
  BOOST_TEST(!silhouette_step_share(behind).has_value());
}


namespace {

double dot3(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// The family's test seed 101: one rod (0.24 long, 0.018 thick, two or three pixels wide) that
// turns 12.4 degrees a frame about a tilted axis; its long axis is the shape's y.
struct RodVideo : Video {
  RodVideo() : Video(0, 14, "family", 101) {}
  Vec3 axis(size_t i) const {
    const Pose34 p = world.object_pose(1, times[i]);
    return {p[1], p[5], p[9]};
  }
  std::vector<Vec3> centres() const {
    std::vector<Vec3> c;
    for (double t : times) {
      const Pose34 p = world.object_pose(1, t);
      c.push_back({p[3], p[7], p[11]});
    }
    return c;
  }
};

// Angle between two lines (radians).
double line_angle(const Vec3& a, const Vec3& b) {
  return std::acos(std::min(1.0, std::fabs(dot3(a, b)) / std::sqrt(dot3(a, a) * dot3(b, b))));
}

}  // namespace

// silhouette_axes against the rod's true axis in every frame that shows it whole or cut by the
// border. The tilt's sign out of the image plane cannot be seen, so a frame's axis is scored
// against the truth and its mirror image in the plane square to the line of sight, the nearer
// of the two. Measured: every frame elongated (seven cut by the border, which take an uncut
// neighbour's tilt), mean 3.2 degrees, worst 7.1. Bounds 6.5 and 14 degrees, twice those: a rod
// two pixels wide reads its length to a pixel or two, which moves a frame's tilt by degrees.
BOOST_AUTO_TEST_CASE(silhouette_axes_follow_a_rod) {
  const RodVideo video;
  const std::vector<ObjectView> views = video.views(1);
  const std::vector<Vec3> centres = video.centres();
  const std::vector<std::optional<Vec3>> axes = silhouette_axes(views, centres);
  BOOST_TEST_REQUIRE(axes.size() == views.size());
  double sum = 0, worst = 0;
  int found = 0;
  for (size_t i = 0; i < axes.size(); ++i) {
    if (!axes[i]) continue;
    const SilhouetteAxis s = silhouette_axis(views[i], centres[i]);
    const Vec3 t = video.axis(i);
    const double along = dot3(t, s.toward);
    const Vec3 mirrored{t[0] - 2 * along * s.toward[0], t[1] - 2 * along * s.toward[1], t[2] - 2 * along * s.toward[2]};
    const double e = std::min(line_angle(*axes[i], t), line_angle(*axes[i], mirrored));
    BOOST_TEST_MESSAGE("frame " << i << ": axis off by " << e / kDegree << " degrees" << (s.clipped ? " (cut)" : ""));
    sum += e;
    worst = std::max(worst, e);
    ++found;
  }
  BOOST_TEST(found == 14);
  BOOST_TEST(sum / std::max(found, 1) < 6.5 * kDegree);
  BOOST_TEST(worst < 14 * kDegree);
}

// A box's, a sphere's or a torus's mask is not a rod's: no axis.
BOOST_AUTO_TEST_CASE(silhouette_axes_need_an_elongated_mask) {
  const Video video(0, 3);
  for (int k = 1; k <= video.world.objects(); ++k)
    for (const auto& axis : silhouette_axes(video.views(k), video.anchors(k))) BOOST_TEST(!axis.has_value());
}

// turn_onto: a rotation (orthonormal, determinant 1) that takes `from` onto `to` and the pivot
// onto the destination; a rod's reverse axis is the same rod, so the turn is the smaller one.
BOOST_AUTO_TEST_CASE(turn_onto_turns_the_axis_about_the_pivot) {
  const Vec3 from{1, 0, 0}, to{0.6, 0.8, 0}, pivot{1, 2, 3}, destination{-1, 0.5, 2};
  for (const Vec3& target : {to, Vec3{-0.6, -0.8, 0}}) {
    const Mat34 m = turn_onto(from, target, pivot, destination);
    const Vec3 p = apply_rigid(m, pivot);
    for (int k = 0; k < 3; ++k) BOOST_TEST(std::fabs(p[k] - destination[k]) < 1e-12);
    const Mat3 r = rotation_of(m);
    const Vec3 turned{r[0], r[3], r[6]};  // R (1, 0, 0)
    for (int k = 0; k < 3; ++k) BOOST_TEST(std::fabs(turned[k] - to[k]) < 1e-12);
    const double det = r[0] * (r[4] * r[8] - r[5] * r[7]) - r[1] * (r[3] * r[8] - r[5] * r[6]) + r[2] * (r[3] * r[7] - r[4] * r[6]);
    BOOST_TEST(std::fabs(det - 1) < 1e-12);
    BOOST_TEST(std::fabs(angle_between(r, {1, 0, 0, 0, 1, 0, 0, 0, 1}) - std::acos(0.6)) < 1e-12);
  }
}

// A rod with no interior point to align by (here: a 3-pixel rim left out of masks two or three
// pixels wide; test seed 101's masks, eroded by a pixel, keep none either): track_object's
// poses carry its first frame's axis along with the silhouettes' turns, and without them
// (silhouette_turns false) leave it unturned. Measured, the carried axis off the true one, mean
// over the later frames: 9.7 degrees, unturned 27.0. Bound: 0.6 of the unturned error (16.2).
BOOST_AUTO_TEST_CASE(a_rod_too_thin_to_align_turns_with_its_silhouettes) {
  const RodVideo video;
  const std::vector<ObjectView> views = video.views(1);
  const std::vector<Vec3> centres = video.centres();
  const auto carried_error = [&](bool silhouettes) {
    AlignmentOptions o;
    o.edge_px = 3;
    o.silhouette_turns = silhouettes;
    const std::vector<Mat34> poses = track_object(views, centres, o);
    const Vec3 first = video.axis(0);
    double sum = 0;
    for (size_t j = 1; j < poses.size(); ++j) {
      const Mat3 a = rotation_of(poses[j]), b = rotation_of(poses[0]);
      Vec3 carried{};  // a b^T first
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
          for (int l = 0; l < 3; ++l) carried[r] += a[static_cast<size_t>(r * 3 + l)] * b[static_cast<size_t>(c * 3 + l)] * first[c];
      sum += line_angle(carried, video.axis(j));
    }
    return sum / static_cast<double>(poses.size() - 1);
  };
  const double with = carried_error(true), without = carried_error(false);
  BOOST_TEST_MESSAGE("carried axis off by " << with / kDegree << " degrees, unturned " << without / kDegree);
  BOOST_TEST(with < 0.6 * without);
}

BOOST_AUTO_TEST_SUITE_END()

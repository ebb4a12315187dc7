// The rigid start's anchors (include/nova/train/motion_init.hpp, outlier_anchors and
// off_path_anchors): a frame whose anchor jumps off the object's path is dropped, a path with
// small wobbles or one that turns keeps every frame, and a jump within the floor (the object's
// own size) stays. And the rows of the frames without an anchor (fill_motion_rows): linear
// between, walking on at the nearest two frames' speed beyond.
#include <boost/test/unit_test.hpp>
#include <vector>

#include "nova/runtime/error.hpp"
#include "nova/train/motion_init.hpp"

namespace nova::test {
namespace {

// An object moving 0.1 a frame along x and slowly away, with a wobble of +-0.01 (a mask's
// centroid moves a little with its outline).
std::vector<Vec3> straight_path(int frames) {
  std::vector<Vec3> p;
  for (int i = 0; i < frames; ++i) p.push_back({0.1 * i, 0.01 * (i % 2 ? 1 : -1), -2.0 - 0.02 * i});
  return p;
}

std::vector<int> frame_numbers(int frames) {
  std::vector<int> f;
  for (int i = 0; i < frames; ++i) f.push_back(i);
  return f;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(motion_start)

BOOST_AUTO_TEST_CASE(an_anchor_off_the_path_is_dropped) {
  std::vector<Vec3> p = straight_path(12);
  p[4][2] -= 1.9;  // a median depth on the background behind the object
  const std::vector<size_t> dropped = outlier_anchors(p, frame_numbers(12), 0.3);
  BOOST_TEST_REQUIRE(dropped.size() == 1u);
  BOOST_TEST(dropped[0] == 4u);
}

BOOST_AUTO_TEST_CASE(an_outlier_at_either_end_is_dropped) {
  for (const size_t at : {size_t(0), size_t(11)}) {
    std::vector<Vec3> p = straight_path(12);
    p[at][2] -= 1.5;
    const std::vector<size_t> dropped = outlier_anchors(p, frame_numbers(12), 0.3);
    BOOST_TEST_REQUIRE(dropped.size() == 1u);
    BOOST_TEST(dropped[0] == at);
  }
}

BOOST_AUTO_TEST_CASE(two_outliers_are_dropped_and_their_neighbours_kept) {
  std::vector<Vec3> p = straight_path(14);
  p[3][0] += 2.0;
  p[9][2] -= 2.0;
  const std::vector<size_t> dropped = outlier_anchors(p, frame_numbers(14), 0.3);
  BOOST_TEST(dropped == (std::vector<size_t>{3, 9}), boost::test_tools::per_element());
}

BOOST_AUTO_TEST_CASE(a_clean_or_curving_path_keeps_every_anchor) {
  BOOST_TEST(outlier_anchors(straight_path(12), frame_numbers(12), 0.3).empty());
  // A bend of the path (a Bezier's turn) is no outlier: 0.1 a frame, then 0.1 a frame upwards.
  std::vector<Vec3> bend;
  for (int i = 0; i < 12; ++i) bend.push_back({0.1 * std::min(i, 6), 0.1 * std::max(0, i - 6), -2.0});
  BOOST_TEST(outlier_anchors(bend, frame_numbers(12), 0.3).empty());
}

BOOST_AUTO_TEST_CASE(a_jump_within_the_floor_stays_and_gaps_count_as_frames) {
  std::vector<Vec3> p = straight_path(12);
  p[5][2] -= 0.25;  // under the floor of 0.3: the object's own size
  BOOST_TEST(outlier_anchors(p, frame_numbers(12), 0.3).empty());
  // Frames 0-5 and 9-14 (the object left the view between): the path's step across the gap is
  // three frames' worth, not an outlier.
  std::vector<Vec3> gap;
  std::vector<int> frames;
  for (int i : {0, 1, 2, 3, 4, 5, 9, 10, 11, 12, 13, 14}) {
    gap.push_back({0.1 * i, 0.0, -2.0});
    frames.push_back(i);
  }
  BOOST_TEST(outlier_anchors(gap, frames, 0.05).empty());
  // Fewer than four anchors: nothing to judge by.
  BOOST_TEST(outlier_anchors({{0, 0, -2}, {5, 0, -2}, {0.2, 0, -2}}, {0, 1, 2}, 0.0).empty());
}

// The start's own rule: the floor is two of the object's median radius. A jump of 0.5 is more
// than four of this path's steps (about 0.1 each), so the floor alone decides.
BOOST_AUTO_TEST_CASE(the_start_keeps_a_jump_within_two_radii) {
  std::vector<Vec3> p = straight_path(12);
  p[5][2] -= 0.5;
  BOOST_TEST(off_path_anchors(p, frame_numbers(12), std::vector<double>(12, 0.3)).empty());
  const std::vector<size_t> dropped = off_path_anchors(p, frame_numbers(12), std::vector<double>(12, 0.2));
  BOOST_TEST_REQUIRE(dropped.size() == 1u);
  BOOST_TEST(dropped[0] == 5u);
}

// Frames 2, 3, 5 and 6 of 9 show the object: 0, 1 lie before them, 4 between, 7, 8 after.
// Exact in binary (steps of 0.25 and 0.5), so the rows compare exactly.
BOOST_AUTO_TEST_CASE(frames_without_the_object_are_filled_in) {
  const std::vector<int> known{2, 3, 5, 6};
  const std::vector<MotionRow> rows{{0.5, 0, 0, 1.0, 0, -2}, {0.75, 0, 0, 1.5, 0.25, -2},
                                    {1.25, 0, 0, 2.5, 0.25, -2.5}, {1.5, 0, 0, 3.0, 0.5, -2.5}};
  const std::vector<MotionRow> all = fill_motion_rows(known, rows, 9);
  BOOST_TEST_REQUIRE(all.size() == 9u);
  const auto same = [](const MotionRow& a, const MotionRow& b) { return a == b; };
  BOOST_TEST(same(all[2], rows[0]));
  BOOST_TEST(same(all[6], rows[3]));
  BOOST_TEST(same(all[4], (MotionRow{1.0, 0, 0, 2.0, 0.25, -2.25})));  // half way
  // Before: frames 2 -> 3 move (0.5, 0.25, 0) a frame, so frame 0 stands two such steps back,
  // its turn that of frame 2.
  BOOST_TEST(same(all[1], (MotionRow{0.5, 0, 0, 0.5, -0.25, -2})));
  BOOST_TEST(same(all[0], (MotionRow{0.5, 0, 0, 0.0, -0.5, -2})));
  // After: frames 5 -> 6 move (0.5, 0.25, 0) a frame.
  BOOST_TEST(same(all[8], (MotionRow{1.5, 0, 0, 4.0, 1.0, -2.5})));
  // One known frame: every frame takes its row; an inconsistent call is refused.
  const std::vector<MotionRow> one = fill_motion_rows({3}, {rows[1]}, 5);
  for (const MotionRow& r : one) BOOST_TEST(same(r, rows[1]));
  BOOST_CHECK_THROW(fill_motion_rows({1, 2}, {rows[0]}, 4), Error);
}

BOOST_AUTO_TEST_SUITE_END()

}  // namespace nova::test

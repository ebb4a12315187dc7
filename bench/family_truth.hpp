#pragma once
// The synthetic family's exact object motion written in a loaded scene's world: what
// `nova-bench motion` scores the rigid objects' start against, and what `nova-bench accuracy
// --exact-motion` starts them from (how far a right motion would take the objects).
#include <array>
#include <vector>

#include "nova/data/synth.hpp"
#include "nova/model/scene.hpp"
#include "nova/sampling/rigid_motion.hpp"

namespace nova::bench {

Mat3 multiply(const Mat3& a, const Mat3& b);
Mat3 transpose(const Mat3& a);
Mat3 rotation_of(const std::array<double, 12>& pose);  // the rotation of a row-major [R | t]
double turn_degrees(const Mat3& r);                    // the angle a rotation turns by

// Which of the scene's objects follows each true object (index k = 1..objects): the one
// sharing the most pixels with it over the video (the scene's own numbering where its masks
// are the given ones).
std::vector<int> match_objects(const Scene& scene, const SynthWorld& world);

// The loaded scene's world is the generator's turned by `turn` and scaled by `scale`
// (llff_poses.hpp's transform), both read off the cameras; `point` carries a generator point
// into it (x -> scale turn x + t, camera 0's centres agreeing).
struct LoadedWorld {
  Mat3 turn{};
  double scale = 1;
  Mat34 point{};
};
LoadedWorld loaded_world(const Scene& scene, const SynthWorld& world);

// The [K, F, 6] motion rows (motion_parameter's layout) of the generator's exact motion, in
// the convention of `start` (initial_motion's rows for the same scene): each object's
// canonical space keeps the start's origin and axes at the first frame its mask shows it,
// and every frame is that frame moved by the object's true motion. Objects no true object
// matches keep their start.
std::vector<float> exact_motion_rows(const Scene& scene, const SynthWorld& world, const std::vector<float>& start);

}  // namespace nova::bench

#pragma once
// Composition specs: which object instances to place where and when, rendered by
// ViewRenderer (view_renderer.hpp). The text format that `nova render --compose SPEC` reads
// and `nova synth` writes next to its ground truth is nova_io's (io/compose_spec_text.hpp).
//
// - A target is one picture: NAME (a plain word; the ground-truth image is NAME.png), the
//   camera of training frame `camera` (processed), and whether the static NeRF is drawn
//   (`background`; without it the instances alone).
// - An instance is object NeRF `object` (1..K) at its time `time` (frame i shows 2 i / N - 1).
//   The same object may appear in several instances.
// - The instance maps a point p of object K at time T (scene coordinates, as trained) to
//   p' = R (p - pivot) + pivot + translate, with R = Rz(RZ) Ry(RY) Rx(RX), angles in degrees
//   (x applied first). Defaults: no rotation, no translation. Without a pivot the instance
//   turns about its object's own centre at time T: the renderer finds it from the object
//   NeRF's density (ViewRenderer::pivot_for, object_centre.hpp) and falls back to the scene
//   origin, with a warning, where the object has no density at T. A renderer samples object
//   K at p = R^T (p' - pivot - translate) + pivot.
#include <array>
#include <optional>
#include <string>
#include <vector>

namespace nova {

struct ComposeInstance {
  int object = 1;
  double time = 0;
  std::array<double, 3> rotate_deg{0, 0, 0};
  std::array<double, 3> translate{0, 0, 0};
  // Empty: not given in the spec; the renderer decides (the object's centre at `time`).
  std::optional<std::array<double, 3>> pivot;
};

struct ComposeTarget {
  std::string name;
  int camera = 0;
  bool background = true;
  std::vector<ComposeInstance> instances;
};

struct ComposeSpec {
  std::vector<ComposeTarget> targets;
  bool empty() const { return targets.empty(); }
};

// R = Rz Ry Rx (degrees), row-major 3x3.
std::array<double, 9> euler_xyz_deg_to_matrix(const std::array<double, 3>& deg);
// The instance's map p -> p' as a row-major 3x4 [R | t'] (t' = pivot + translate - R pivot),
// about `pivot`.
std::array<double, 12> instance_transform(const ComposeInstance& inst, const std::array<double, 3>& pivot);
// The same about the instance's own pivot, which must be set (Error, kExitInternal, if not:
// a spec without pivot= is placed by a renderer, which decides the pivot).
std::array<double, 12> instance_transform(const ComposeInstance& inst);

}  // namespace nova

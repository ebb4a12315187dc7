#pragma once
// Composition specs: which object instances to place where and when, read by
// `nova render --compose SPEC` and written by `nova synth` next to its ground truth.
//
// Text format, one statement per line, '#' starts a comment, blank lines ignored:
//
//   nova-compose 1
//   target NAME camera=FRAME [background=1|0]
//   instance object=K time=T [rotate=RX,RY,RZ] [translate=TX,TY,TZ] [pivot=PX,PY,PZ]
//
// - `target` starts a target; the `instance` lines after it belong to it. NAME is a plain
//   word (letters, digits, '_', '-', '.'); the ground-truth image is NAME.png.
// - camera=FRAME: render with the (processed) camera of training frame FRAME.
// - background=1 (default) draws the static NeRF; 0 draws the instances alone.
// - object=K: object NeRF K (1..K). time=T: the object's time (frame i shows 2 i / N - 1).
//   The same object may appear in several instances.
// - The instance maps a point p of object K at time T (scene coordinates, as trained) to
//   p' = R (p - pivot) + pivot + translate, with R = Rz(RZ) Ry(RY) Rx(RX), angles in degrees
//   (x applied first). Defaults: no rotation, no translation. Without pivot= the instance
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

// Parses spec text; `origin` names the file in error messages. Throws nova::Error.
ComposeSpec parse_compose_spec(const std::string& text, const std::string& origin);
ComposeSpec read_compose_spec(const std::string& path);
// Writes with round-trip precision (parse(format(s)) == s); an instance without a pivot is
// written without pivot=.
std::string format_compose_spec(const ComposeSpec& spec);

// R = Rz Ry Rx (degrees), row-major 3x3.
std::array<double, 9> euler_xyz_deg_to_matrix(const std::array<double, 3>& deg);
// The instance's map p -> p' as a row-major 3x4 [R | t'] (t' = pivot + translate - R pivot),
// about `pivot`.
std::array<double, 12> instance_transform(const ComposeInstance& inst, const std::array<double, 3>& pivot);
// The same about the instance's own pivot, which must be set (Error, kExitInternal, if not:
// a spec without pivot= is placed by a renderer, which decides the pivot).
std::array<double, 12> instance_transform(const ComposeInstance& inst);

}  // namespace nova

#pragma once
// The text format of composition specs (compose_spec.hpp), read by `nova render --compose
// SPEC` and written by `nova synth` next to its ground truth.
//
// One statement per line, '#' starts a comment, blank lines ignored:
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
// - rotate= (degrees, R = Rz Ry Rx), translate= and pivot= place the instance as
//   compose_spec.hpp says; without pivot= the renderer decides it.
#include <string>

#include "nova/model/compose_spec.hpp"

namespace nova {

// Parses spec text; `origin` names the file in error messages. Throws nova::Error.
ComposeSpec parse_compose_spec(const std::string& text, const std::string& origin);
ComposeSpec read_compose_spec(const std::string& path);
// Writes with round-trip precision (parse(format(s)) == s); an instance without a pivot is
// written without pivot=.
std::string format_compose_spec(const ComposeSpec& spec);

}  // namespace nova

#pragma once
// A small hash-grid field for the suites that build object fields: 4 levels of 4-`max_res`
// cells, 2^10 entries, one 8-wide hidden layer, the unit box an NDC scene resolves to.
#include "nova/model/fields.hpp"

namespace nova::test {

inline FieldConfig small_hash_field(int max_res = 32, ObjectMotion motion = ObjectMotion::None) {
  FieldConfig f;
  f.encoding = Encoding::HashGrid;
  f.hash.levels = 4;
  f.hash.log2_size = 10;
  f.hash.min_resolution = 4;
  f.hash.max_resolution = max_res;
  f.hash.bound = 1.0f;  // as scene_field resolves it for an NDC scene
  f.depth = 1;
  f.width = 8;
  f.skip = -1;
  f.motion = motion;
  return f;
}

}  // namespace nova::test

#pragma once
// A small hash-grid field for the suites that build object fields: 4 levels of 4-`max_res`
// cells, 2^10 entries, one 8-wide hidden layer, the unit box an NDC scene resolves to; and a
// run of two objects' fields at fixed points and given times.
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "harness.hpp"
#include "nova/graph/executor.hpp"
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

struct FieldRun {
  std::vector<float> raw;          // [K, M, 5]: rgb, sigma, blend
  std::vector<std::string> names;  // the parameters, in graph order
};

// Two objects' fields at fixed canonical points (uniform in +-0.9, seed 1) and `times` (one per
// row). Each parameter gets values uniform in +-1 from the seed `seed_of(name)` gives, or keeps
// its initial values where that gives none.
inline FieldRun run_object_fields(const FieldConfig& f, const std::vector<float>& times,
                                  const std::function<std::optional<unsigned>(const std::string&)>& seed_of) {
  const size_t K = 2, M = times.size() / K;
  Graph g;
  Tensor p = g.input("p", Shape{K, M, 3});
  Tensor t = g.input("t", Shape{K, M, 1});
  Tensor out = build_object_fields(p, t, f);
  g.keep(out);
  Executor ex(runtime(), g);
  ex.set(p, random_floats(K * M * 3, -0.9f, 0.9f, 1));
  ex.set(t, times);
  FieldRun run;
  for (Tensor w : g.parameters()) {
    run.names.push_back(w.info().name);
    if (const std::optional<unsigned> seed = seed_of(w.info().name))
      ex.set(w, random_floats(w.shape().numel(), -1.0f, 1.0f, *seed));
  }
  ex.forward();
  run.raw = ex.get(out);
  return run;
}

}  // namespace nova::test

#pragma once
// The one harness of the op table (op_table.hpp): runs an entry at a shape against its
// float64 reference and checks its gradients, on guarded executors (every op is checked not
// to write outside its tensors); finds the op classes an entry builds and those the library
// defines; times an entry for the timing mode.
#include <set>
#include <string>

#include "op_table.hpp"

namespace nova::test {

// Fixture of the op table's suite: the runtime records every launch (the coverage check reads
// them).
struct RecordLaunches {
  RecordLaunches() { runtime().record_launches(true); }
};

// Forward against the reference, the gradient against its float64 derivative, central
// differences where the entry is differentiable (or the entry's own check).
void check_entry(const OpEntry& entry, const OpShape& shape);

// Op classes (unqualified C++ class names) of the nodes of the graph `entry` builds at `shape`.
std::set<std::string> op_classes_built(const OpEntry& entry, const OpShape& shape);

// Every concrete op class the library defines: classes of host/ and include/nova/ deriving
// (directly or through a base) from nova::Op, parsed from the sources.
std::set<std::string> library_op_classes();

struct OpTimingResult {
  double seconds = 0;  // per forward + backward, mean over the timed runs
  double flops = 0;    // per forward + backward (OpEntry::flops)
};
// Runs the entry's graph forward + backward `reps` times (after one untimed run) and returns
// the mean time of one.
OpTimingResult time_entry(const OpEntry& entry, const OpShape& shape, int reps);

}  // namespace nova::test

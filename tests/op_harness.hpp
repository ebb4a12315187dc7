#pragma once
// The one harness of the op table (op_table.hpp): runs an entry at a shape against its
// float64 reference and checks its gradients, on guarded executors (every op is checked not
// to write outside its tensors); finds the op classes an entry builds and those the library
// defines. Timing the table is nova-bench's (`nova-bench ops`).
#include <functional>
#include <map>
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
// differences where the entry is differentiable (or the entry's own check); a shape the
// device cannot run (OpEntry::prepare) is skipped with a message.
void check_entry(const OpEntry& entry, const OpShape& shape);

// Checks of their own of the entries without a `reference`, by entry name
// (op_table_checks.cpp); each builds its executors with guarded_options().
using OwnCheck = std::function<void(const OpShape&)>;
const std::map<std::string, OwnCheck>& own_checks();

// Op classes (unqualified C++ class names) of the nodes of the graph `entry` builds at `shape`.
std::set<std::string> op_classes_built(const OpEntry& entry, const OpShape& shape);

// Every concrete op class the library defines: classes of host/ and include/nova/ deriving
// (directly or through a base) from nova::Op, parsed from the sources.
std::set<std::string> library_op_classes();

}  // namespace nova::test

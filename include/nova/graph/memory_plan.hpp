#pragma once
// Buffer reuse from tensor lifetimes: tensors whose lifetimes do not overlap share memory.
#include <cstddef>
#include <vector>

namespace nova {

struct Lifetime {
  size_t bytes = 0;
  int first = 0;  // first schedule step that writes or reads it
  int last = 0;   // last schedule step that reads it (inclusive)
};

struct MemoryPlan {
  std::vector<size_t> offsets;  // one per Lifetime, aligned
  size_t peak_bytes = 0;        // the arena size this plan needs
  size_t total_bytes = 0;       // what one buffer per tensor would need
};

// Places every tensor at the lowest aligned offset free during its whole lifetime, largest
// first (the greedy-by-size strategy of TFLite's arena planner).
MemoryPlan plan_memory(const std::vector<Lifetime>& tensors, size_t alignment);

}  // namespace nova

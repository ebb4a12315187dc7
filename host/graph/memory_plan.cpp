#include "nova/graph/memory_plan.hpp"

#include <algorithm>
#include <numeric>

namespace nova {

MemoryPlan plan_memory(const std::vector<Lifetime>& tensors, size_t alignment) {
  const auto align = [&](size_t x) { return (x + alignment - 1) / alignment * alignment; };
  MemoryPlan plan;
  plan.offsets.assign(tensors.size(), 0);
  std::vector<size_t> order(tensors.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return tensors[a].bytes > tensors[b].bytes; });

  struct Placed {
    size_t offset, end;
    int first, last;
  };
  std::vector<Placed> placed;
  for (size_t i : order) {
    const Lifetime& t = tensors[i];
    const size_t size = align(std::max<size_t>(t.bytes, 1));
    plan.total_bytes += size;
    // Regions of already placed tensors alive at the same time, by offset.
    std::vector<Placed> live;
    for (const Placed& p : placed)
      if (p.first <= t.last && t.first <= p.last) live.push_back(p);
    std::sort(live.begin(), live.end(),
              [](const Placed& a, const Placed& b) { return a.offset < b.offset; });
    size_t offset = 0;
    for (const Placed& p : live) {
      if (offset + size <= p.offset) break;  // fits in the gap before p
      offset = std::max(offset, p.end);
    }
    plan.offsets[i] = offset;
    placed.push_back({offset, offset + size, t.first, t.last});
    plan.peak_bytes = std::max(plan.peak_bytes, offset + size);
  }
  return plan;
}

}  // namespace nova

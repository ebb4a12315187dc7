#pragma once
// Two ranks holding identical rays, in one process (distributed.hpp): the sum over ranks of a
// value is twice this rank's. A deterministic stand-in for a second rank where one process
// must run a graph built for data-parallel training (the op table); the sum is exact (a
// doubling), so it gives the bits the in-process reducer of two ranks with the same rays gives
// (thread_reducer.hpp; test_rank_sum.cpp checks both agree).
#include <vector>

#include "nova/graph/distributed.hpp"

namespace nova::test {

class TwinRanksReducer final : public GradientReducer {
 public:
  int rank() const override { return 0; }
  int size() const override { return 2; }
  void sum(std::vector<float>& values) override {
    for (float& v : values) v += v;
  }
};

}  // namespace nova::test

#pragma once
// Ranks as threads of one process (distributed.hpp): each deposits its values, then every rank
// sums all deposits in rank order, as the MPI reducer of `nova train` does.
#include <barrier>
#include <exception>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "nova/graph/distributed.hpp"

namespace nova::test {

class ThreadReducer final : public GradientReducer {
 public:
  struct Shared {
    explicit Shared(int n) : slots(static_cast<size_t>(n)), sync(n) {}
    std::vector<std::vector<float>> slots;
    std::barrier<> sync;
  };
  ThreadReducer(Shared& s, int rank) : s_(s), rank_(rank) {}
  int rank() const override { return rank_; }
  int size() const override { return static_cast<int>(s_.slots.size()); }
  void sum(std::vector<float>& values) override {
    s_.slots[static_cast<size_t>(rank_)] = values;
    s_.sync.arrive_and_wait();
    for (size_t i = 0; i < values.size(); ++i) {
      float t = 0.0f;
      for (const auto& slot : s_.slots) t += slot[i];
      values[i] = t;
    }
    s_.sync.arrive_and_wait();
  }

 private:
  Shared& s_;
  int rank_;
};

// Runs body(rank, reducer) on `ranks` threads; returns each rank's error message (empty: none).
// A rank that throws leaves the others waiting at its next sum, so bodies must not throw
// between collectives on one rank only.
inline std::vector<std::string> run_ranks(int ranks, const std::function<void(int, GradientReducer&)>& body) {
  ThreadReducer::Shared shared(ranks);
  std::vector<std::string> errors(static_cast<size_t>(ranks));
  std::vector<std::thread> threads;
  for (int r = 0; r < ranks; ++r)
    threads.emplace_back([&, r] {
      try {
        ThreadReducer reducer(shared, r);
        body(r, reducer);
      } catch (const std::exception& e) {
        errors[static_cast<size_t>(r)] = e.what();
      }
    });
  for (std::thread& t : threads) t.join();
  return errors;
}

}  // namespace nova::test

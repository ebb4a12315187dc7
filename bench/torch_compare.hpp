#pragma once
// nova's reference-MLP training step beside the same step in PyTorch (torch_peer.hpp), in one
// run, alternating step by step.
#include <iosfwd>
#include <string>
#include <vector>

#include "nova/model/mlp.hpp"
#include "nova/runtime/runtime.hpp"

namespace nova::bench {

// Prints a table (batch, pass, nova and PyTorch samples/s, ratio nova / PyTorch) to `out` and
// its CSV rows to `csv`; where `python` is empty or has no torch, one line saying so. PyTorch
// runs on `device` (cpu, or cuda: nova on a GPU beside PyTorch on the same GPU) with
// `threads` host threads (0: the machine's hardware threads).
void compare_with_torch(Runtime& rt, const MlpConfig& c, const std::vector<long>& batches,
                        int repeats, const std::string& python, int threads,
                        const std::string& device, std::ostream& out, std::ostream& csv);

}  // namespace nova::bench

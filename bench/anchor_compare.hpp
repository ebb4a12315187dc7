#pragma once
// nova's training step beside the NOVA code's (bench/anchor_run.hpp), round by round, and the
// ratios NOVA code / nova.
#include <iosfwd>
#include <string>
#include <vector>

namespace nova::bench {

// Seconds per step of one side in one round: the median of that round's timed steps.
struct PhaseSeconds {
  double pretrain = 0, joint = 0;
};

struct AnchorRound {
  PhaseSeconds nova, anchor;
};

// Each side's fastest round across rounds (phases apart), and the median round.
PhaseSeconds best_round(const std::vector<AnchorRound>& rounds, bool anchor);
PhaseSeconds median_round(const std::vector<AnchorRound>& rounds, bool anchor);

// The rounds, then each side's best round and the ratios (the headline), then the median
// round's ratios.
void print_anchor_comparison(const std::vector<AnchorRound>& rounds, std::ostream& out);

// "round,phase,nova_seconds_per_step,nova_code_seconds_per_step,nova_code_over_nova" rows.
std::string anchor_csv(const std::vector<AnchorRound>& rounds);

}  // namespace nova::bench

// nova beside the NOVA code (bench/anchor_compare.hpp).
#include "anchor_compare.hpp"

#include <algorithm>
#include <iomanip>
#include <ostream>
#include <sstream>

#include "bench.hpp"

namespace nova::bench {
namespace {

const PhaseSeconds& side(const AnchorRound& r, bool anchor) { return anchor ? r.anchor : r.nova; }

void ratio_line(std::ostream& out, const char* phase, double nova, double anchor) {
  out << "  " << std::left << std::setw(13) << phase << std::right << std::fixed << std::setprecision(3) << "nova "
      << std::setw(8) << nova << " s   NOVA code " << std::setw(8) << anchor << " s   NOVA code / nova "
      << std::setprecision(2) << anchor / nova << "\n";
}

}  // namespace

PhaseSeconds best_round(const std::vector<AnchorRound>& rounds, bool anchor) {
  PhaseSeconds b = side(rounds.at(0), anchor);
  for (const AnchorRound& r : rounds) {
    b.pretrain = std::min(b.pretrain, side(r, anchor).pretrain);
    b.joint = std::min(b.joint, side(r, anchor).joint);
  }
  return b;
}

PhaseSeconds median_round(const std::vector<AnchorRound>& rounds, bool anchor) {
  std::vector<double> pre, joint;
  for (const AnchorRound& r : rounds) {
    pre.push_back(side(r, anchor).pretrain);
    joint.push_back(side(r, anchor).joint);
  }
  return {median(pre), median(joint)};
}

void print_anchor_comparison(const std::vector<AnchorRound>& rounds, std::ostream& out) {
  out << "\nnova beside the NOVA code, " << rounds.size()
      << " rounds alternating; a round's time is the median of its timed steps (seconds per step):\n"
      << "round  nova pretrain  NOVA code pretrain  nova joint  NOVA code joint\n"
      << std::fixed << std::setprecision(3);
  for (size_t i = 0; i < rounds.size(); ++i) {
    const AnchorRound& r = rounds[i];
    out << std::setw(5) << i + 1 << std::setw(15) << r.nova.pretrain << std::setw(20) << r.anchor.pretrain
        << std::setw(12) << r.nova.joint << std::setw(17) << r.anchor.joint << "\n";
  }
  // Other load on a shared machine only ever lengthens a step, and alternating gives both sides
  // the same chances at a quiet stretch: each side's fastest round is its least disturbed.
  const PhaseSeconds bn = best_round(rounds, false), ba = best_round(rounds, true);
  out << "each side's best round (other load only lengthens steps; the fastest round is the least disturbed):\n";
  ratio_line(out, "pretraining", bn.pretrain, ba.pretrain);
  ratio_line(out, "joint", bn.joint, ba.joint);
  const PhaseSeconds mn = median_round(rounds, false), ma = median_round(rounds, true);
  out << "each side's median round" << (rounds.size() % 2 ? "" : " (the slower middle one)") << ":\n";
  ratio_line(out, "pretraining", mn.pretrain, ma.pretrain);
  ratio_line(out, "joint", mn.joint, ma.joint);
}

std::string anchor_csv(const std::vector<AnchorRound>& rounds) {
  std::ostringstream csv;
  csv << "round,phase,nova_seconds_per_step,nova_code_seconds_per_step,nova_code_over_nova\n";
  for (size_t i = 0; i < rounds.size(); ++i) {
    const AnchorRound& r = rounds[i];
    csv << i + 1 << ",pretrain," << r.nova.pretrain << "," << r.anchor.pretrain << "," << r.anchor.pretrain / r.nova.pretrain
        << "\n"
        << i + 1 << ",joint," << r.nova.joint << "," << r.anchor.joint << "," << r.anchor.joint / r.nova.joint << "\n";
  }
  return csv.str();
}

}  // namespace nova::bench

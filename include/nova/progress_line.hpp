#pragma once
// The one-line training progress report `nova train` prints (and nova-bench accuracy with it).
#include <cstdio>
#include <string>

#include "nova/trainer.hpp"

namespace nova {

// Seconds as "12m05s", or "1h02m" from an hour on.
inline std::string clock_text(double s) {
  const long t = static_cast<long>(s + 0.5);
  char buf[32];
  if (t >= 3600)
    std::snprintf(buf, sizeof buf, "%ldh%02ldm", t / 3600, t / 60 % 60);
  else
    std::snprintf(buf, sizeof buf, "%ldm%02lds", t / 60, t % 60);
  return buf;
}

// "step N/TOTAL  PHASE loss ...  psnr ... dB  lr ...  R rays/s  ELAPSED  eta ETA[  mlp on P% of samples]",
// without a newline.
inline std::string progress_line(const TrainProgress& p) {
  char line[256];
  std::snprintf(line, sizeof line, "step %7ld/%ld  %-8s loss %.5f  psnr %5.2f dB  lr %.2e  %6.0f rays/s  %s  eta %s",
                p.step, p.total, p.phase.c_str(), p.loss, p.psnr, p.lr, p.rays_per_s,
                clock_text(p.seconds).c_str(), clock_text(p.eta_seconds).c_str());
  std::string out = line;
  if (p.kept >= 0) {
    std::snprintf(line, sizeof line, "  mlp on %.0f%% of samples", 100.0 * p.kept);
    out += line;
  }
  return out;
}

}  // namespace nova

#pragma once
// The one-line training progress report `nova train` prints (and nova-bench accuracy with it).
#include <cstdio>
#include <string>
#include <unistd.h>

#include "nova/train/trainer.hpp"

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

// Whether stderr is a terminal: progress there redraws one line ('\r'); in a log it is
// written as whole lines.
inline bool stderr_is_terminal() {
  static const bool tty = ::isatty(::fileno(stderr)) != 0;
  return tty;
}

// "WHAT DONE/TOTAL" on stderr after each of TOTAL items: redrawn in place on a terminal, in a
// log one line per tenth of the work.
inline void count_progress(const std::string& what, size_t done, size_t total) {
  if (stderr_is_terminal()) {
    std::fprintf(stderr, "\r%s %zu/%zu%s", what.c_str(), done, total, done >= total ? "\n" : "");
  } else {
    const size_t every = total >= 10 ? total / 10 : 1;
    if (done % every != 0 && done < total) return;
    std::fprintf(stderr, "%s %zu/%zu\n", what.c_str(), done, total);
  }
  std::fflush(stderr);
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

#pragma once
// The progress line of a long render (nova render, nova eval): rays done, rays/s and ETA on
// stderr, from the second second of a view on and at most once a second, so that short views
// print nothing and long ones (a 480x270 `reference` view takes minutes on a CPU) show life.
#include <chrono>
#include <cstdio>
#include <string>

#include "nova/train/progress_line.hpp"

namespace nova::cli {

class RenderProgress {
 public:
  // Call before each view with its name.
  void start(std::string view) {
    view_ = std::move(view);
    begin_ = last_ = std::chrono::steady_clock::now();
    printed_ = false;
  }
  void operator()(size_t done, size_t total) {
    const auto now = std::chrono::steady_clock::now();
    const double secs = std::chrono::duration<double>(now - begin_).count();
    const bool last = done >= total;
    if (!last && (secs < 2.0 || std::chrono::duration<double>(now - last_).count() < 1.0)) return;
    if (last && !printed_) return;
    last_ = now;
    printed_ = true;
    const double rate = secs > 0 ? static_cast<double>(done) / secs : 0.0;
    const double eta = rate > 0 ? static_cast<double>(total - done) / rate : 0.0;
    const bool tty = stderr_is_terminal();
    std::fprintf(stderr, "%s%s: rays %zu/%zu  %.0f rays/s  %s  eta %s%s", tty ? "\r" : "", view_.c_str(), done, total,
                 rate, clock_text(secs).c_str(), clock_text(eta).c_str(), last || !tty ? "\n" : "");
    std::fflush(stderr);
  }

 private:
  std::string view_;
  std::chrono::steady_clock::time_point begin_, last_;
  bool printed_ = false;
};

}  // namespace nova::cli

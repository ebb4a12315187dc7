#pragma once
// The pieces of `nova-bench tradeoff` that need no device: settings (a name, `nova train`
// overrides and a GEMM provider), the training budget and evaluation points, PSNR-vs-time
// curves, the time at which a curve first reaches a PSNR level and the speedup at equal
// PSNR, the CSV and the PNG plot. Defined in bench/tradeoff.cpp, which nova_tests links too,
// so that tests/test_tradeoff.cpp checks the same code nova-bench runs. Needs OpenCV (nova_io
// builds only).
#include <cmath>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "nova/model/scene.hpp"

namespace nova::tradeoff {

// ---- settings -----------------------------------------------------------------------------

// One configuration to train: its name, its `nova train` overrides and its GEMM provider.
struct Setting {
  std::string name;
  std::vector<std::pair<std::string, std::string>> overrides;  // nova train key = value, in order
  std::string gemm;  // "tuned", "clblast", "kernels", "host", or "" (the process default: NOVA_GEMM, else tuned)
};

std::string trim(const std::string& s);

// "NAME[:KEY=VALUE[,KEY=VALUE...]]". NAME: letters, digits, '.', '_', '+', '-' (it names a
// run folder and a CSV field). KEY: a `nova train` option (checked later, against the build:
// see unknown_keys) or `gemm` / `NOVA_GEMM` with the value tuned, clblast or kernels (the
// GEMM modes of include/nova/ops/linalg/gemm.hpp). Error (exit 2)
// naming the setting on anything else.
Setting parse_setting(const std::string& text, const std::string& origin = "--setting");

// One setting a line in parse_setting's syntax; blank lines and '#' comments are skipped.
// Duplicate names are an error.
std::vector<Setting> parse_settings_text(const std::string& text, const std::string& origin);

void check_unique_names(const std::vector<Setting>& settings);

// The tradeoff axes around the quick preset; the first one is the baseline. Settings whose
// configuration equals an earlier one's (quick already has 32 samples, width 64, tuned GEMMs and,
// once `occupancy` exists, skipping on) are trained once and reported under both names.
std::vector<Setting> default_settings();

// The keys of `s` that this build's `nova train` does not know (`nova train --help`).
std::vector<std::string> unknown_keys(const Setting& s);

// ---- budget and evaluation points ---------------------------------------------------------

// "--budget": a scale of the configured schedule ("1", "0.5"), or seconds of training per
// setting ("300s").
struct Budget {
  double scale = 1.0;    // steps mode: pretrain-steps, steps and lr-decay-steps times this
  double seconds = 0.0;  // > 0: seconds mode (the configured schedule, cut at this much training)
};

Budget parse_budget(const std::string& text);

// Steps after which a steps-mode run is evaluated: the end of pretraining (when there is
// one), then `segments` equal parts of joint training (or of pretraining when there are no
// joint steps). Increasing, no duplicates, no zero.
std::vector<long> segment_ends(long pretrain, long joint, int segments);

// `count` of `n` items, evenly spread, first and last included (all when count >= n).
std::vector<int> spread_indices(int n, int count);

// ---- curves -------------------------------------------------------------------------------

// One evaluation of a run: where training stood and what it scored.
struct Point {
  int segment = 0;
  long steps = 0;
  double seconds = 0;  // training wall-clock so far (evaluation and warm-up excluded)
  double psnr = 0, ssim = 0;
  double rays_per_s = 0;  // over this segment (0 for segment 0)
};

// The evaluations of one setting, in training order.
struct Curve {
  std::string setting;  // the name it is reported under
  std::string run;      // the setting that was trained (itself, or an earlier equal one)
  std::vector<Point> points;
};

// The training time at which the curve first reaches `level` dB, linearly interpolated
// between the two evaluations around the crossing; nullopt when it never does.
std::optional<double> time_to_reach(const std::vector<Point>& points, double level);

// How many times faster `other` reaches `level` than `base`: t_base / t_other; nullopt
// ("n/a") when either never reaches it.
std::optional<double> speedup_at(const Curve& base, const Curve& other, double level);

std::string fmt(double v, int decimals);

std::string csv_text(const std::vector<Curve>& curves);

// ---- the plot -----------------------------------------------------------------------------


// One polyline of the plot, under its legend label.
struct Series {
  std::string label;
  std::vector<std::pair<double, double>> xy;  // (seconds, PSNR)
};

// PSNR (y) against training seconds (x): one coloured polyline with markers per series, a
// legend, axis labels and ticks, and a dashed line at `level` when it is finite. RGB.
Image8 plot(const std::vector<Series>& series, const std::string& title, double level = NAN,
            int width = 1000, int height = 640);

}  // namespace nova::tradeoff

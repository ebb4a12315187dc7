// nova-bench tradeoff: trains one scene under several settings (samples, width, GEMM
// provider, empty-space skipping, or any `nova train` overrides) and records, for each, PSNR
// against training wall-clock time: the run is trained in segments (Trainer::run up to a
// step, as `nova train --steps N` then `--resume` does, bit for bit) and camera 0 is
// evaluated after each one, outside the clock. Writes tradeoff.csv, tradeoff.png and
// summary.txt, and prints the speedup of every setting over the first (the baseline) at
// equal PSNR. Built only with nova_io (scenes, metrics and the plot need OpenCV).
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>

#include "bench.hpp"
#include "nova/ops/linalg/gemm.hpp"
#include "nova/io/image_io.hpp"
#include "nova/data/scene_io.hpp"
#include "nova/data/synth.hpp"
#include "nova/eval/evaluation.hpp"
#include "nova/train/run_folder.hpp"
#include "nova/runtime/runtime.hpp"
#include "nova/train/trainer.hpp"
#include "nova/model/view_renderer.hpp"
#include "options.hpp"
#include "tradeoff.hpp"

namespace nova::bench {
namespace {
namespace fs = std::filesystem;
using namespace nova::tradeoff;
using clock_type = std::chrono::steady_clock;

constexpr const char* kUsage =
    "usage: nova-bench tradeoff [--scene DIR] [--out DIR] [--budget SCALE|SECONDSs] [--segments N]\n"
    "                           [--setting NAME:KEY=V,KEY=V ...] [--settings FILE] [--base KEY=V,...]\n"
    "                           [--eval-views N] [--target-psnr DB] [--device SEL] [--force] [--dry-run]\n"
    "\n"
    "Trains the scene once per setting and writes, for each, camera-0 PSNR against training\n"
    "wall-clock seconds (evaluation and a short untimed warm-up that compiles the kernels are\n"
    "excluded): OUT/tradeoff.csv, OUT/tradeoff.png, OUT/summary.txt, OUT/runs/NAME/ (config.ini,\n"
    "metrics.jsonl). The first setting is the baseline; the summary gives every setting's speedup\n"
    "at equal PSNR: t_baseline(L) / t_setting(L), the training times at which each first reaches\n"
    "the level L (interpolated between evaluations), n/a when one never does.\n"
    "\n"
    "options:\n"
    "  --scene DIR        scene to train (default: the default synthetic scene, generated into OUT/scene)\n"
    "  --out DIR          output folder (default: tradeoff); must not exist unless --force\n"
    "  --budget B         a scale of every setting's schedule (pretrain-steps, steps and lr-decay-steps\n"
    "                     times B; default 1), or seconds of training per setting, e.g. 300s\n"
    "  --segments N       evaluations over joint training (default 6), plus step 0 and the end of\n"
    "                     pretraining; with a seconds budget, N equal slices of it\n"
    "  --setting SPEC     NAME:KEY=VALUE,KEY=VALUE (nova train options, and gemm=tuned|clblast|kernels\n"
    "                     for the GEMM mode, as NOVA_GEMM); repeat for several; replaces the defaults\n"
    "  --settings FILE    one SPEC a line ('#' comments); 'default' is the built-in list\n"
    "  --base KEY=V,...   nova train options applied to every setting before its own\n"
    "  --preset P         the preset every setting starts from (default quick)\n"
    "  --eval-views N     camera-0 views evaluated after each segment, spread over time (default 4;\n"
    "                     0: all)\n"
    "  --target-psnr DB   the equal-PSNR level (default: the baseline's final PSNR - 0.5 dB)\n"
    "  --device SEL       OpenCL device, as nova's --device\n"
    "  --keep-checkpoints keep OUT/runs/NAME/checkpoint.bin (deleted after evaluation otherwise)\n"
    "  --no-warmup        do not train 1 + 3 untimed steps first (kernel compiles then count)\n"
    "  --force            replace an existing OUT\n"
    "  --dry-run          print the plan and stop\n"
    "\n"
    "Default settings (quick and the tradeoff axes; settings equal to an earlier one are trained\n"
    "once; settings with an option this build's nova train does not know are skipped with a\n"
    "warning):\n";

struct Planned {
  Setting setting;
  TrainConfig config;
  std::string gemm;     // resolved: tuned, clblast or kernels
  std::string same_as;  // an earlier setting with the same configuration, trained once
};

// One training of a setting.
struct RunResult {
  std::vector<Point> points;
  double warmup_s = 0, eval_s = 0, joint_rays_per_s = 0;
  std::string error;  // the failure, when it failed
};

std::string env_gemm() {
  const char* e = std::getenv("NOVA_GEMM");
  const std::string v = e ? e : "";
  if (v.empty()) return "tuned";
  parse_gemm_provider(v, "NOVA_GEMM");  // validates
  return v;
}

std::string overrides_text(const Setting& s) {
  std::string t;
  for (const auto& [k, v] : s.overrides) t += (t.empty() ? "" : ",") + k + "=" + v;
  if (!s.gemm.empty()) t += (t.empty() ? "" : ",") + std::string("gemm=") + s.gemm;
  return t.empty() ? "(no overrides)" : t;
}

void write_atomically(const std::string& path, const std::string& text) {
  {
    std::ofstream o(path + ".tmp", std::ios::binary);
    o << text;
    if (!o.flush()) throw Error("cannot write '" + path + "'", kExitInternal);
  }
  fs::rename(path + ".tmp", path);
}

// The ground truth evaluated after every segment: camera 0 at `count` times spread over the
// video (the paper's protocol on a subset), else held-out views.
std::vector<GroundTruthView> eval_views(const Scene& scene, int count, std::string* kind) {
  std::vector<const GroundTruthView*> all;
  for (const std::string k : {"cam0", "heldout"}) {
    for (const auto& v : scene.gt_views)
      if (v.kind == k) all.push_back(&v);
    if (!all.empty()) {
      *kind = k;
      break;
    }
  }
  if (all.empty())
    throw Error("scene '" + scene.source + "' has no ground-truth views (camera 0 at every time, or held-out "
                "cameras): the tradeoff needs them (nova synth scenes have them)");
  std::stable_sort(all.begin(), all.end(), [](auto* a, auto* b) { return a->time_index < b->time_index; });
  std::vector<GroundTruthView> out;
  for (int i : spread_indices(static_cast<int>(all.size()), count <= 0 ? static_cast<int>(all.size()) : count))
    out.push_back(*all[static_cast<size_t>(i)]);
  return out;
}

// Mean PSNR and SSIM of the views as `nova eval` scores them (learnt blending, its default for
// the scene's own views).
std::pair<double, double> evaluate(Runtime& rt, Trainer& trainer, const TrainConfig& config, const Scene& scene,
                                   const std::vector<GroundTruthView>& views) {
  const Checkpoint ck = trainer.checkpoint();
  ViewRenderer renderer(rt, config, ray_geometry(scene), ck);
  return mean_scores(score_views(renderer, scene.num_objects, views, /*hard_blend=*/false));
}

double since(clock_type::time_point t) { return std::chrono::duration<double>(clock_type::now() - t).count(); }

RunResult run_setting(const Planned& pl, const Scene& scene, const DeviceInfo& device, const Budget& budget,
                      int segments, const std::vector<GroundTruthView>& views, const std::string& run_dir,
                      bool warmup, bool keep_checkpoint) {
  RunResult r;
  const TrainConfig& c = pl.config;
  Runtime rt(device, false);
  set_gemm_provider(rt, pl.gemm.empty() ? GemmProvider::Tuned : parse_gemm_provider(pl.gemm, "gemm"));
  if (warmup) {
    // Builds every kernel and GEMM program both phases use (PoCL compiles a new CLBlast
    // program in 18-35 s), so that compiles do not count as training time.
    const auto t0 = clock_type::now();
    TrainConfig w = c;
    w.pretrain_steps = std::min(w.pretrain_steps, 1);
    w.steps = std::min(w.steps, 3);
    w.augment_start = 0;
    w.augment_every = std::min(w.augment_every, 2);
    const std::string dir = run_dir + ".warmup";
    try {
      Trainer t(rt, scene, w, dir);
      t.run();
    } catch (...) {
      fs::remove_all(dir);
      throw;
    }
    fs::remove_all(dir);
    r.warmup_s = since(t0);
  }
  Trainer trainer(rt, scene, c, run_dir);
  const long total = trainer.total_steps();
  double train_s = 0, joint_s = 0;
  long joint_steps = 0;
  const auto eval_point = [&](int segment, double seg_s, long seg_steps) {
    const auto t0 = clock_type::now();
    const auto [p, s] = evaluate(rt, trainer, c, scene, views);
    const double e = since(t0);
    r.eval_s += e;
    const double rate = seg_s > 0 ? c.rays * double(seg_steps) / seg_s : 0;
    r.points.push_back({segment, trainer.step(), train_s, p, s, rate});
    std::ostringstream line;
    line << "  " << std::left << std::setw(14) << pl.setting.name << std::right << " segment " << segment
         << "  step " << std::setw(6) << trainer.step() << "/" << total << "  train " << std::fixed
         << std::setprecision(1) << std::setw(7) << train_s << " s  " << std::setprecision(0) << std::setw(6) << rate
         << " rays/s  PSNR " << std::setprecision(2) << p << " dB  SSIM " << std::setprecision(4) << s << "  (eval "
         << std::setprecision(1) << e << " s)";
    std::cerr << line.str() << "\n";
  };
  // Trains up to `end`; the clock stops at the last step's progress report (after the queue
  // has finished), before the checkpoint written at the end of every Trainer::run.
  const auto train_to = [&](long end) {
    const long from = trainer.step();
    clock_type::time_point stop{};
    const auto t0 = clock_type::now();
    trainer.run([&](const TrainProgress& p) {
      if (p.step == std::min(end, total)) stop = clock_type::now();
    }, end);
    if (stop == clock_type::time_point{}) stop = clock_type::now();
    const double s = std::chrono::duration<double>(stop - t0).count();
    train_s += s;
    // Steps beyond pretraining count towards the joint rate (a slice across the phase
    // boundary is split by steps, approximately).
    const long joint_in = std::max(0L, trainer.step() - std::max<long>(from, c.pretrain_steps));
    if (trainer.step() > from && joint_in > 0) {
      joint_s += s * double(joint_in) / double(trainer.step() - from);
      joint_steps += joint_in;
    }
    return s;
  };

  eval_point(0, 0, 0);
  if (budget.seconds <= 0) {
    int segment = 0;
    for (long end : segment_ends(c.pretrain_steps, c.steps, segments)) {
      const long from = trainer.step();
      const double s = train_to(end);
      eval_point(++segment, s, trainer.step() - from);
    }
  } else {
    const long chunk = std::max(1, c.log_every);
    for (int segment = 1; segment <= segments && trainer.step() < total; ++segment) {
      const double until = budget.seconds * segment / segments;
      const long from = trainer.step();
      const double before = train_s;
      while (train_s < until && trainer.step() < total) train_to(trainer.step() + chunk);
      eval_point(segment, train_s - before, trainer.step() - from);
    }
  }
  r.joint_rays_per_s = joint_s > 0 ? c.rays * double(joint_steps) / joint_s : 0;
  if (!keep_checkpoint) fs::remove(RunFolder(run_dir).checkpoint_path());
  return r;
}

std::string speedup_text(const std::optional<double>& s) { return s ? fmt(*s, 2) + "x" : "n/a"; }

// Settings: --setting, else --settings FILE, else the defaults.
std::vector<Setting> read_settings(const std::vector<std::string>& specs, const std::string& file) {
  std::vector<Setting> settings;
  if (!specs.empty()) {
    if (file != "default") throw Error("give --setting or --settings FILE, not both");
    for (const std::string& s : specs) settings.push_back(parse_setting(s));
  } else if (file != "default") {
    std::ifstream in(file);
    if (!in) throw Error("--settings: file '" + file + "' cannot be read");
    std::stringstream text;
    text << in.rdbuf();
    settings = parse_settings_text(text.str(), file);
  } else {
    settings = default_settings();
  }
  check_unique_names(settings);
  return settings;
}

// Every setting resolved to a configuration before anything is written. A setting with an
// option this build's nova train does not know is skipped with a warning (named in *skipped);
// one equal to an earlier setting is marked to share its training.
std::vector<Planned> plan_settings(const std::vector<Setting>& settings, const Setting& base,
                                   const std::string& preset_arg, const Budget& budget,
                                   std::vector<std::string>* skipped) {
  const std::string default_gemm = env_gemm();
  std::vector<Planned> plan;
  for (const Setting& s : settings) {
    if (const auto unknown = unknown_keys(s); !unknown.empty()) {
      std::string keys;
      for (const auto& k : unknown) keys += (keys.empty() ? "'" : ", '") + k + "'";
      std::cerr << "nova-bench tradeoff: warning: skipping setting '" << s.name << "': " << keys
                << (unknown.size() > 1 ? " are not options" : " is not an option")
                << " of this build's nova train (nova train --help)\n";
      skipped->push_back(s.name);
      continue;
    }
    Planned p{s, {}, {}, {}};
    std::string preset = preset_arg;
    for (const auto* list : {&base.overrides, &s.overrides})
      for (const auto& [k, v] : *list)
        if (k == "preset") preset = v;
    try {
      p.config = preset_config(preset);
      p.config.checkpoint_every = 1000000000;  // only at segment ends (outside the clock)
      for (const auto* list : {&base.overrides, &s.overrides})
        for (const auto& [k, v] : *list)
          if (k != "preset") set_config_value(p.config, k, v);
      if (budget.seconds <= 0) {
        p.config.pretrain_steps = static_cast<int>(std::lround(p.config.pretrain_steps * budget.scale));
        p.config.steps = static_cast<int>(std::lround(p.config.steps * budget.scale));
        p.config.lr_decay_steps = std::max(1, static_cast<int>(std::lround(p.config.lr_decay_steps * budget.scale)));
      }
      if (p.config.pretrain_steps + p.config.steps <= 0) throw Error("it trains no steps");
      validate(p.config);
    } catch (const Error& e) {
      throw Error("setting '" + s.name + "': " + e.what());
    }
    p.gemm = !s.gemm.empty() ? s.gemm : !base.gemm.empty() ? base.gemm : default_gemm;
    const std::string key = format_config(p.config) + "gemm = " + p.gemm;
    for (const Planned& q : plan)
      if (q.same_as.empty() && format_config(q.config) + "gemm = " + q.gemm == key) p.same_as = q.setting.name;
    plan.push_back(std::move(p));
  }
  if (plan.empty()) throw Error("no setting left to train (every one was skipped)");
  return plan;
}

using Scenes = std::map<std::pair<int, int>, Scene>;  // (factor, holdout) -> scene

// The scene folder once per factor and hold-out of the plan; each must have ground truth.
Scenes load_scenes(const std::string& dir, const std::vector<Planned>& plan, int eval_count) {
  Scenes scenes;
  for (const Planned& p : plan) {
    const auto k = std::make_pair(p.config.factor, p.config.holdout);
    if (scenes.count(k)) continue;
    LoadOptions lo;
    lo.factor = p.config.factor;
    lo.load_gt = true;
    Scene sc = load_scene(dir, lo);
    if (p.config.holdout > 0) hold_out_frames(sc, p.config.holdout);
    std::string kind;
    eval_views(sc, eval_count, &kind);
    scenes.emplace(k, std::move(sc));
  }
  return scenes;
}

// One line per setting: its overrides and what it trains (or the earlier setting it shares).
void print_plan(const std::vector<Planned>& plan, const std::vector<std::string>& skipped, const Budget& budget) {
  int distinct = 0;
  long distinct_steps = 0;
  for (const Planned& p : plan) {
    std::cout << "  " << std::left << std::setw(14) << p.setting.name << std::setw(36) << overrides_text(p.setting);
    if (!p.same_as.empty()) {
      std::cout << " same configuration as " << p.same_as << ": not trained again\n";
      continue;
    }
    ++distinct;
    distinct_steps += long(p.config.pretrain_steps) + p.config.steps;
    std::cout << " " << p.config.pretrain_steps << " + " << p.config.steps << " steps, " << p.config.rays
              << " rays x " << p.config.samples << " samples, width " << p.config.field.width << ", gemm " << p.gemm
              << "\n";
  }
  for (const std::string& s : skipped) std::cout << "  " << std::left << std::setw(14) << s << "skipped (see the warning)\n";
  std::cout << "  baseline: " << plan[0].setting.name << "; " << distinct << " trainings"
            << (budget.seconds > 0 ? " of up to " + fmt(budget.seconds, 0) + " s each"
                                   : ", " + std::to_string(distinct_steps) + " steps in all")
            << "\n";
}

// The equal-PSNR level: --target-psnr, else the baseline's final PSNR - 0.5 dB (NaN before
// the baseline has a point).
double equal_psnr_level(const std::vector<Planned>& plan, const std::vector<Curve>& curves,
                        const std::optional<double>& target) {
  if (target) return *target;
  for (const Curve& c : curves)
    if (c.setting == plan[0].setting.name && !c.points.empty()) return c.points.back().psnr - 0.5;
  return NAN;
}

// summary.txt: the plan's head, then per setting its last point, the time it reached `level`
// and its speedup over the baseline there, then what was left untimed or skipped.
std::string summary_text(const std::string& head, const std::vector<Planned>& plan, const std::vector<Curve>& curves,
                         const std::map<std::string, RunResult>& results, double level, bool from_target,
                         const std::vector<std::string>& skipped) {
  const Planned& b = plan[0];
  const Curve* bc = nullptr;
  for (const Curve& c : curves)
    if (c.setting == b.setting.name) bc = &c;
  std::ostringstream s;
  s << head << "\n"
    << std::left << std::setw(15) << "setting" << std::setw(15) << "run" << std::right << std::setw(7) << "steps"
    << std::setw(10) << "train s" << std::setw(12) << "rays/s jnt" << std::setw(8) << "PSNR" << std::setw(8)
    << "SSIM" << std::setw(10) << "t(L) s" << "  speedup at equal PSNR\n";
  for (const Planned& p : plan) {
    const std::string run = p.same_as.empty() ? p.setting.name : p.same_as;
    s << std::left << std::setw(15) << p.setting.name << std::setw(15) << (run == p.setting.name ? "" : "= " + run);
    const Curve* c = nullptr;
    for (const Curve& x : curves)
      if (x.setting == p.setting.name) c = &x;
    const auto rit = results.find(run);
    if (!c || c->points.empty()) {
      s << std::right << "  " << (rit != results.end() && !rit->second.error.empty() ? "failed: " + rit->second.error : "not run yet") << "\n";
      continue;
    }
    const Point& last = c->points.back();
    const auto t = std::isfinite(level) ? time_to_reach(c->points, level) : std::nullopt;
    s << std::right << std::setw(7) << last.steps << std::setw(10) << fmt(last.seconds, 1) << std::setw(12)
      << fmt(rit != results.end() ? rit->second.joint_rays_per_s : 0, 0) << std::setw(8) << fmt(last.psnr, 2)
      << std::setw(8) << fmt(last.ssim, 4) << std::setw(10) << (t ? fmt(*t, 1) : "n/a") << "  "
      << (bc && std::isfinite(level) ? speedup_text(speedup_at(*bc, *c, level)) : "n/a")
      << (p.setting.name == b.setting.name ? " (baseline)" : "") << "\n";
  }
  if (std::isfinite(level))
    s << "equal-PSNR level L = " << fmt(level, 2) << " dB ("
      << (from_target ? "--target-psnr" : "baseline " + b.setting.name + "'s final PSNR - 0.5 dB")
      << "); speedup = t_" << b.setting.name << "(L) / t_setting(L), n/a when one never reaches L\n";
  double warm = 0, ev = 0;
  for (const auto& [name, r] : results) warm += r.warmup_s, ev += r.eval_s;
  s << "untimed: warm-up " << fmt(warm, 0) << " s, evaluation " << fmt(ev, 0) << " s\n";
  for (const std::string& k : skipped) s << "skipped: " << k << " (an option this build's nova train does not know)\n";
  return s.str();
}

// The plot at `path`: one series per training, named by every setting that shares it.
void write_plot(const std::string& path, const std::vector<Planned>& plan, const std::map<std::string, RunResult>& results,
                const std::string& title, double level) {
  std::vector<Series> series;
  for (const Planned& p : plan) {
    if (!p.same_as.empty()) continue;
    const auto it = results.find(p.setting.name);
    if (it == results.end() || it->second.points.empty()) continue;
    Series se;
    se.label = p.setting.name;
    for (const Planned& q : plan)
      if (q.same_as == p.setting.name) se.label += " = " + q.setting.name;
    for (const Point& pt : it->second.points) se.xy.emplace_back(pt.seconds, pt.psnr);
    series.push_back(std::move(se));
  }
  write_png(path + ".tmp.png", plot(series, title, level));
  fs::rename(path + ".tmp.png", path);
}

}  // namespace

int tradeoff(const Args& raw_args) {
  std::vector<std::string> args = raw_args;
  const std::vector<std::string> specs = take_repeated(args, "setting", "NAME:KEY=VALUE,...");
  const Options o(args, {{"scene", ""}, {"out", "tradeoff"}, {"budget", "1"}, {"segments", "6"},
                         {"settings", "default"}, {"base", ""}, {"preset", "quick"}, {"eval-views", "4"},
                         {"target-psnr", "auto"}, {"device", ""}, {"keep-checkpoints", "off"},
                         {"no-warmup", "off"}, {"force", "off"}, {"dry-run", "off"}});
  if (o.help()) {
    std::cout << kUsage;
    for (const Setting& s : default_settings()) std::cout << "  " << std::left << std::setw(14) << s.name << overrides_text(s) << "\n";
    return 0;
  }
  const Budget budget = parse_budget(o.str("budget"));
  const long segments = o.integer("segments");
  if (segments < 1 || segments > 1000) throw Error("--segments must be 1 to 1000, got " + o.str("segments"));
  const long eval_count = o.integer("eval-views");
  if (eval_count < 0) throw Error("--eval-views must be 0 (all) or more, got " + o.str("eval-views"));
  std::optional<double> target;
  if (o.str("target-psnr") != "auto") {
    try {
      target = std::stod(o.str("target-psnr"));
    } catch (const std::exception&) {
      throw Error("--target-psnr must be a number of dB or auto, got '" + o.str("target-psnr") + "'");
    }
  }
  const std::string out = [&] {
    std::string d = o.str("out");
    while (d.size() > 1 && d.back() == '/') d.pop_back();
    if (d.empty()) throw Error("--out must name a folder");
    return d;
  }();

  const std::vector<Setting> settings = read_settings(specs, o.str("settings"));
  const Setting base = parse_setting("base:" + o.str("base"), "--base");
  for (const std::string& k : unknown_keys(base))
    throw Error("--base: '" + k + "' is not an option of nova train (nova train --help)");
  std::vector<std::string> skipped;
  const std::vector<Planned> plan = plan_settings(settings, base, o.str("preset"), budget, &skipped);

  // Scene: the given one must load (with every setting's factor and hold-out) and have
  // ground truth; the default one is generated later.
  const std::string scene_arg = o.str("scene");
  Scenes scenes;
  if (!scene_arg.empty()) {
    if (!fs::is_directory(scene_arg)) throw Error("--scene: folder '" + scene_arg + "' does not exist");
    std::error_code ec;
    const fs::path so = fs::weakly_canonical(scene_arg, ec), oo = fs::weakly_canonical(out, ec);
    const auto rel = so.lexically_relative(oo);
    if (!rel.empty() && *rel.begin() != "..")
      throw Error("--scene '" + scene_arg + "' lies inside --out '" + out + "'");
    scenes = load_scenes(scene_arg, plan, static_cast<int>(eval_count));
  }
  const DeviceInfo device = select_device(o.str("device"));
  const bool out_exists = fs::exists(out);
  if (out_exists && !o.flag("force") && !o.flag("dry-run"))
    throw Error("output folder '" + out + "' already exists (pass --force to replace it)");

  // The plan.
  std::ostringstream head;
  head << "nova-bench tradeoff: scene "
       << (scene_arg.empty() ? "(the default synthetic scene, generated into " + out + "/scene)" : scene_arg)
       << ", preset " << o.str("preset") << ", budget "
       << (budget.seconds > 0 ? fmt(budget.seconds, 0) + " s of training per setting"
                              : "x" + fmt(budget.scale, 3) + " of the schedule")
       << ", " << segments << " segments, " << (eval_count ? std::to_string(eval_count) : std::string("all"))
       << " camera-0 views per evaluation, device " << device.name << "\n";
  {
    const std::string cache = gemm_tuning_cache_path();
    head << "GEMM tuning cache (gemm=tuned): " << (cache.empty() ? "none" : cache)
         << (!cache.empty() && fs::exists(cache)
                 ? ""
                 : host_gemm_available(device) ? " (missing: tuned runs the host BLAS " + host_blas_library() + ")"
                                               : std::string(" (missing: tuned runs the table's CLBlast; run nova tune first)"))
         << "\n";
  }
  std::cout << head.str();
  print_plan(plan, skipped, budget);
  if (o.flag("dry-run")) {
    if (out_exists && !o.flag("force")) std::cout << "note: '" << out << "' exists: the run needs --force\n";
    return 0;
  }

  // From here on OUT is ours; a failure before the first result removes it.
  if (out_exists) fs::remove_all(out);
  fs::create_directories(out + "/runs");
  bool any_result = false;
  int failures = 0;
  try {
    std::string scene_dir = scene_arg;
    if (scene_dir.empty()) {
      scene_dir = out + "/scene";
      std::cerr << "generating the default synthetic scene into " << scene_dir << "\n";
      write_synthetic_scene(scene_dir, "default", 0);
      scenes = load_scenes(scene_dir, plan, static_cast<int>(eval_count));
    }
    std::vector<Curve> curves;
    std::map<std::string, RunResult> results;
    std::string summary;
    const auto report = [&]() {
      const double level = equal_psnr_level(plan, curves, target);
      summary = summary_text(head.str(), plan, curves, results, level, target.has_value(), skipped);
      write_atomically(out + "/tradeoff.csv", csv_text(curves));
      const std::string scene_name =
          scene_arg.empty() ? std::string("default synthetic scene") : fs::path(scene_arg).filename().string();
      write_plot(out + "/tradeoff.png", plan, results, "PSNR against training time (" + scene_name + ")", level);
      write_atomically(out + "/summary.txt", summary);
    };

    const Scene* any_scene = &scenes.begin()->second;
    std::string kind;
    const auto views_for = [&](const Scene& sc) { return eval_views(sc, static_cast<int>(eval_count), &kind); };
    views_for(*any_scene);
    std::cerr << "evaluating " << views_for(*any_scene).size() << " " << kind << " views after each segment\n";
    for (const Planned& p : plan) {
      const std::string run = p.same_as.empty() ? p.setting.name : p.same_as;
      if (p.same_as.empty()) {
        const Scene& sc = scenes.at({p.config.factor, p.config.holdout});
        std::cerr << "setting " << p.setting.name << ": " << overrides_text(p.setting) << "\n";
        RunResult r;
        try {
          r = run_setting(p, sc, device, budget, static_cast<int>(segments), views_for(sc),
                          out + "/runs/" + p.setting.name, !o.flag("no-warmup"), o.flag("keep-checkpoints"));
        } catch (const Error& e) {
          // One failing setting (a provider this device lacks, divergence) does not stop the rest.
          std::cerr << "nova-bench tradeoff: setting '" << p.setting.name << "' failed: " << e.what() << "\n";
          r.error = e.what();
          ++failures;
        }
        results[p.setting.name] = r;
      }
      const RunResult& r = results[run];
      if (!r.points.empty()) {
        curves.push_back({p.setting.name, run, r.points});
        any_result = true;
      }
      report();
    }
    std::cout << "\n" << summary << "wrote " << out << "/tradeoff.csv, " << out << "/tradeoff.png, " << out
              << "/summary.txt and " << out << "/runs/\n";
  } catch (...) {
    if (!any_result) fs::remove_all(out);
    throw;
  }
  // Outputs stay when a setting failed (the others' curves are valid); the exit code says so.
  return failures > 0 ? kExitInternal : 0;
}

}  // namespace nova::bench

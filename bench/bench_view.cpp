// nova-bench view: renders views of a trained run with early ray termination off (every
// sample of every ray, empty space still skipped when the run has grids) and, per set of
// check points, in passes with nothing stopped (the pure cost of passes), in passes always
// (the renderer before its adaptive switch) and adaptive (the default), timed alternately in
// one run. Prints the time ratio to off, the rays terminated, the chunks run in passes, the
// field evaluations saved, the largest difference from the unterminated render, and the
// break-even fraction of stopped rays that EarlyTermination::pays_from stands for. Built only
// with nova_io (it loads the run's scene for its cameras).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "bench.hpp"
#include "nova/data/scene_io.hpp"
#include "nova/train/run_folder.hpp"
#include "nova/runtime/runtime.hpp"
#include "nova/model/view_renderer.hpp"
#include "options.hpp"

namespace nova::bench {
namespace {

// "default;8,16,24" -> {{}, {8, 16, 24}}: one setting per group, {} the renderer's S / 2.
std::vector<std::vector<int>> parse_checks(const std::string& text) {
  std::vector<std::vector<int>> out;
  std::stringstream groups(text);
  for (std::string g; std::getline(groups, g, ';');) {
    std::vector<int> c;
    if (g != "default") {
      std::stringstream items(g);
      for (std::string item; std::getline(items, item, ',');) {
        try {
          c.push_back(std::stoi(item));
        } catch (const std::exception&) {
          throw Error("--checks: '" + item + "' is not an integer (groups like 'default;8,16,24')");
        }
      }
    }
    out.push_back(c);
  }
  if (out.empty()) throw Error("--checks: no setting");
  return out;
}

std::string checks_name(const std::string& kind, const std::vector<int>& c, int samples) {
  if (c.empty()) return kind + "@" + std::to_string(samples / 2);
  std::string s = kind + "@";
  for (size_t i = 0; i < c.size(); ++i) s += (i ? "," : "") + std::to_string(c[i]);
  return s;
}

double max_abs_diff(const std::vector<float>& a, const std::vector<float>& b) {
  double m = 0;
  for (size_t i = 0; i < a.size(); ++i) m = std::max(m, std::fabs(static_cast<double>(a[i]) - b[i]));
  return m;
}

struct Setting {
  std::string name;
  EarlyTermination termination;
  bool probe = false;           // in passes, nothing stopped: measures what passes cost
  std::vector<double> seconds;  // per view: median over repeats
  size_t rays = 0, terminated = 0, evaluated = 0, late = 0, samples = 0, passes = 0, chunks = 0, split = 0;
  double rgb_diff = 0, acc_diff = 0, mask_diff = 0, depth_diff = 0;
};

}  // namespace

int view(const Args& args) {
  const Options o(args, {{"run", ""}, {"scene", ""}, {"views", "3"}, {"repeats", "3"},
                         {"checks", "default"}, {"no-skip", "off"}, {"device", ""}});
  if (o.help()) {
    std::cout << o.usage("nova-bench view") << "\n--checks: settings separated by ';', each 'default' (S / 2) "
                 "or sample indices 'a,b,...'\n";
    return 0;
  }
  if (o.str("run").empty()) throw Error("--run RUN is required (a trained run folder)");
  const RunFiles run = RunFolder(o.str("run")).read();
  const std::string scene_dir = o.str("scene").empty() ? run.scene : o.str("scene");
  if (scene_dir.empty()) throw Error("run '" + o.str("run") + "' does not name its scene: pass --scene");
  LoadOptions lo;
  lo.factor = run.config.factor;
  lo.static_only = run.config.static_only;
  lo.load_gt = false;
  const Scene scene = load_scene(scene_dir, lo);
  const int views = static_cast<int>(o.integer("views")), repeats = static_cast<int>(o.integer("repeats"));
  if (views < 1 || repeats < 1) throw Error("--views and --repeats must be >= 1");

  Runtime rt(select_device(o.str("device")), false);
  ViewRenderer renderer(rt, run.config, ray_geometry(scene), run.checkpoint);
  renderer.set_skip_empty_space(!o.flag("no-skip"));
  std::vector<Setting> settings(1);
  settings[0].name = "off";
  settings[0].termination.on = false;
  for (const auto& c : parse_checks(o.str("checks"))) {
    // split: a floor of 0 stops no ray, so its time over off is the cost of the passes alone;
    // passes: every chunk in passes (pays_from 0); adaptive: the renderer's default.
    Setting split, always, adaptive;
    split.termination.checks = always.termination.checks = adaptive.termination.checks = c;
    split.termination.below = 0.0f;
    split.termination.pays_from = always.termination.pays_from = 0.0f;
    split.probe = true;
    split.name = checks_name("split", c, run.config.samples);
    always.name = checks_name("passes", c, run.config.samples);
    adaptive.name = checks_name("adaptive", c, run.config.samples);
    settings.insert(settings.end(), {split, always, adaptive});
  }
  auto apply = [&](const Setting& s) { renderer.set_early_termination(s.termination); };

  std::vector<ViewRequest> requests;
  const size_t F = scene.frames.size();
  for (int v = 0; v < views; ++v) {
    const Frame& f = scene.frames[std::min(F - 1, static_cast<size_t>(v) * F / static_cast<size_t>(views))];
    ViewRequest req;
    req.camera = f.camera;
    req.hard_blend = false;  // nova eval's default for the scene's own views
    req.instances = scene_instances(scene.num_objects, f.time);
    requests.push_back(req);
  }
  std::cout << "device " << rt.info().name << "; run " << o.str("run") << ": " << run.config.samples
            << " samples per ray, " << requests.size() << " view(s) of " << requests[0].camera.width << "x"
            << requests[0].camera.height << ", empty-space skipping "
            << (renderer.skips_empty_space() ? "on" : "off (no grids or --no-skip)") << "; median of " << repeats
            << " renders per view and setting, settings alternating, after a warm-up\n\n";

  for (const ViewRequest& req : requests) {
    std::vector<std::vector<double>> times(settings.size());
    ViewImage full;
    for (int rep = -1; rep < repeats; ++rep)
      for (size_t k = 0; k < settings.size(); ++k) {
        Setting& s = settings[k];
        apply(s);
        const auto a = std::chrono::steady_clock::now();
        const ViewImage img = renderer.render(req);
        const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - a).count();
        if (rep < 0) {  // the warm-up builds the graphs; its image and counts are the record
          const RenderStats& st = renderer.last_stats();
          s.rays += st.rays;
          s.terminated += st.terminated;
          s.evaluated += st.evaluated;
          s.late += st.late;
          s.samples += st.samples;
          s.passes += st.passes;
          s.chunks += st.split.size();
          s.split += static_cast<size_t>(std::count(st.split.begin(), st.split.end(), 1));
          if (k == 0) {
            full = img;
          } else {
            s.rgb_diff = std::max(s.rgb_diff, max_abs_diff(img.rgb, full.rgb));
            s.acc_diff = std::max(s.acc_diff, max_abs_diff(img.acc, full.acc));
            s.depth_diff = std::max(s.depth_diff, max_abs_diff(img.depth, full.depth));
            for (size_t m = 0; m < img.masks.size(); ++m)
              s.mask_diff = std::max(s.mask_diff, max_abs_diff(img.masks[m], full.masks[m]));
          }
          continue;
        }
        times[k].push_back(secs);
      }
    for (size_t k = 0; k < settings.size(); ++k) {
      std::sort(times[k].begin(), times[k].end());
      settings[k].seconds.push_back(times[k][times[k].size() / 2]);
    }
  }

  auto total = [](const Setting& s) {
    double t = 0;
    for (double x : s.seconds) t += x;
    return t;
  };
  const Setting& off = settings[0];
  std::cout << std::left << std::setw(16) << "setting" << std::right << std::setw(10) << "s/view" << std::setw(10)
            << "time/off" << std::setw(12) << "terminated" << std::setw(12) << "evals/off" << std::setw(12)
            << "evals/all" << std::setw(8) << "passes" << std::setw(10) << "in passes" << std::setw(11) << "rgb diff" << std::setw(11) << "acc diff"
            << std::setw(11) << "mask diff" << std::setw(12) << "depth diff" << "\n";
  std::ostringstream csv;
  csv << "setting,seconds_per_view,time_over_off,rays_terminated,evaluations_over_off,evaluations_over_all,passes,"
         "chunks_in_passes,max_rgb_diff,max_acc_diff,max_mask_diff,max_depth_diff\n";
  std::ostringstream even;
  for (const Setting& s : settings) {
    const double per_view = total(s) / static_cast<double>(requests.size());
    const double ratio = total(s) / total(off);
    const double term = static_cast<double>(s.terminated) / static_cast<double>(s.rays);
    const double evals = static_cast<double>(s.evaluated) / static_cast<double>(off.evaluated);
    const double all = static_cast<double>(s.evaluated) / static_cast<double>(s.samples);
    const double in_passes = static_cast<double>(s.split) / static_cast<double>(std::max<size_t>(1, s.chunks));
    std::cout << std::left << std::setw(16) << s.name << std::right << std::fixed << std::setprecision(3)
              << std::setw(10) << per_view << std::setw(10) << ratio << std::setw(12) << term << std::setw(12)
              << evals << std::setw(12) << all << std::setw(8) << s.passes << std::setw(10) << in_passes
              << std::scientific << std::setprecision(1)
              << std::setw(11) << s.rgb_diff << std::setw(11) << s.acc_diff << std::setw(11) << s.mask_diff
              << std::setw(12) << s.depth_diff << std::defaultfloat << "\n";
    csv << s.name << "," << per_view << "," << ratio << "," << term << "," << evals << "," << all << "," << s.passes
        << "," << in_passes << "," << s.rgb_diff << "," << s.acc_diff << "," << s.mask_diff << "," << s.depth_diff
        << "\n";
    // Per chunk, off takes t = a + bE (a: the dense part of a graph run, E evaluations) and
    // split 2a + bE, so o = ratio - 1 = a / t; stopping a fraction f of the rays saves about
    // f b L (L: the late evaluations, if stopped rays have the average share of them), which
    // pays from f = a / (b L) = o / ((1 - o) L / E).
    if (s.probe && s.evaluated > 0) {
      const double o = ratio - 1, late = static_cast<double>(s.late) / static_cast<double>(s.evaluated);
      even << s.name << ": passes cost " << std::fixed << std::setprecision(3) << o << " of the time without them, "
           << late << " of the evaluations come after the first check: break-even at "
           // o < 0: the passes measured faster than none (noise), so stopping pays from any fraction
           << (late > 0 && o < 1 ? std::max(0.0, o / ((1 - o) * late)) : 1.0) << " of the rays stopped (pays_from "
           << EarlyTermination{}.pays_from << ")\n" << std::defaultfloat;
    }
  }
  std::cout << "\n(terminated: fraction of rays stopped before their last segment; evals: field evaluations, "
               "against the render without termination and against every sample of every NeRF; diffs: largest "
               "|difference| from the render without termination, over all views; in passes: fraction of chunks "
               "rendered in passes)\n\n"
            << even.str() << "\nCSV\n"
            << csv.str();
  return 0;
}

}  // namespace nova::bench

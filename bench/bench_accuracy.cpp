// nova-bench accuracy: trains and evaluates a list of scenes (named sets of a seeded synthetic
// family, other synthetic scenes, the real scenes of the shared data folder) with one
// configuration, as `nova train` + `nova eval` would (the same Trainer, scene loading and
// scoring functions), and writes per-scene and per-set PSNR / SSIM / training time: a table,
// OUT/accuracy.csv, OUT/accuracy.json, OUT/accuracy.png and OUT/pictures/SCENE.png. Built
// only with nova_io (scenes, metrics, pictures).
#include <array>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>
#include <unistd.h>

#include "accuracy.hpp"
#include "bench.hpp"
#include "nova/eval/evaluation.hpp"
#include "nova/io/image_io.hpp"
#include "nova/data/synth.hpp"
#include "nova/io/charts.hpp"
#include "nova/train/progress_line.hpp"
#include "nova/train/run_folder.hpp"
#include "nova/runtime/runtime.hpp"
#include "nova/train/motion_init.hpp"
#include "nova/train/trainer.hpp"
#include "nova/model/view_renderer.hpp"
#include "family_truth.hpp"
#include "options.hpp"

namespace nova::bench {
namespace {
namespace fs = std::filesystem;
using namespace nova::accuracy;
using clock_type = std::chrono::steady_clock;

constexpr const char* kUsage =
    "usage: nova-bench accuracy [--scenes LIST] [--out DIR] [--preset quick|reference] [--config FILE]\n"
    "                           [--set KEY=VALUE ...] [--data DIR] [--reuse] [--exact-motion] [--device SEL]\n"
    "                           [--dry-run]\n"
    "\n"
    "Trains every scene of LIST with one configuration and evaluates it as nova eval does; prints\n"
    "per-scene and per-set PSNR / SSIM / training time and writes OUT/accuracy.csv,\n"
    "OUT/accuracy.json, OUT/accuracy.png (PSNR bars by set, PSNR against training time) and\n"
    "OUT/pictures/SCENE.png (renders beside ground truth). Scenes are generated into\n"
    "OUT/scenes/NAME (reused when there), runs go to OUT/runs/NAME.\n"
    "\n"
    "options:\n"
    "  --scenes LIST   comma list of sets and scenes (default dev):\n"
    "                    dev = family:1..4 (for choosing methods and defaults),\n"
    "                    test = family:101..104 (only reported, never tuned on),\n"
    "                    deforming = synth:deforming:101..104 (the test worlds, objects changing shape; reported)\n"
    "                    real = balloon, fern, lego;  all = dev + test + real\n"
    "                    family:SEED        the seeded synthetic family (nova synth --preset family)\n"
    "                    synth:PRESET:SEED  another nova synth scene (synth:tiny:0, synth:default:0)\n"
    "                    balloon            nvidia_balloon1, --factor 4 --holdout 4 (held-out frames)\n"
    "                    fern               llff_fern, --holdout 8 (held-out frames)\n"
    "                    lego               dnerf_lego_tiny, scored on its test split (nova eval --split test)\n"
    "  --out DIR       output folder (default accuracy); may exist (scenes and runs in it are reused)\n"
    "  --preset P      quick or reference (default quick)\n"
    "  --config FILE   nova train config file (key = value lines; a run's config.ini works)\n"
    "  --set KEY=VALUE any nova train option, for every scene, after the scene's own protocol\n"
    "                  options (factor, holdout); repeatable\n"
    "  --data DIR      the real scenes' folder (default: shared/data beside the repository)\n"
    "  --reuse         skip training where OUT/runs/NAME holds a finished run with the same config.ini\n"
    "  --exact-motion  family scenes, rigid objects: start each object's trajectory from the\n"
    "                  generator's exact motion instead of the frames' alignment (with --set\n"
    "                  lr-motion=0 it is kept): how far a right motion takes the objects\n"
    "  --device SEL    OpenCL device, as nova's --device\n"
    "  --dry-run       print the plan and stop\n";

struct Planned {
  SceneSpec spec;
  TrainConfig config;
  std::string source;  // scene folder (real) or where the synthetic scene goes
};

void write_atomically(const std::string& path, const std::string& text) {
  {
    std::ofstream o(path + ".tmp", std::ios::binary);
    o << text;
    if (!o.flush()) throw Error("cannot write '" + path + "'", kExitInternal);
  }
  fs::rename(path + ".tmp", path);
}

void write_png_atomically(const std::string& path, const Image8& image) {
  const std::string tmp = path + ".tmp.png";
  write_png(tmp, image);
  fs::rename(tmp, path);
}

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

double since(clock_type::time_point t) { return std::chrono::duration<double>(clock_type::now() - t).count(); }

// --data, else the first shared/data folder found beside an ancestor of the source tree, the
// executable or the working directory (a shared/data folder beside the repository).
std::string data_folder(const std::string& given) {
  if (!given.empty()) return given;
  std::vector<fs::path> starts;
#ifdef NOVA_SOURCE_DIR
  starts.emplace_back(NOVA_SOURCE_DIR);
#endif
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) starts.push_back(exe.parent_path());
  starts.push_back(fs::current_path(ec));
  for (const fs::path& s : starts)
    for (fs::path p = fs::weakly_canonical(s, ec); !p.empty(); p = p.parent_path()) {
      if (fs::is_directory(p / "shared" / "data")) return (p / "shared" / "data").string();
      if (p == p.parent_path()) break;
    }
  return "";
}

// The synthetic scene in `dir`, generated unless its synth.txt names the same preset and seed.
void ensure_synthetic(const SceneSpec& s, const std::string& dir) {
  const std::string info = read_text(dir + "/synth.txt");
  const std::string want = "preset " + s.preset + "\nseed " + std::to_string(s.seed) + "\n";
  if (fs::is_directory(dir) && info.find(want) != std::string::npos) return;
  std::cerr << "  generating " << s.name << " into " << dir << (fs::exists(dir) ? " (replacing a different scene)" : "")
            << "\n";
  std::cerr << "  " << write_synthetic_scene(dir, s.preset, s.seed, true) << "\n";
}

// A run started from the generator's exact motion (--exact-motion) holds this file: its
// config.ini alone does not tell it from a run started from the frames' alignment.
constexpr const char* kExactMotionMarker = "exact_motion.txt";

// Whether `run_dir` holds a finished run of exactly this configuration, scene and start.
bool finished_run(const std::string& run_dir, const TrainConfig& config, const Scene& scene, bool exact_motion) {
  const RunFolder run(run_dir);
  if (!fs::exists(run.checkpoint_path())) return false;
  if (read_text(run.config_path()) != run_config_text(config, scene.source)) return false;
  if (fs::exists(run_dir + "/" + kExactMotionMarker) != exact_motion) return false;
  try {
    const Checkpoint ck = read_checkpoint(run.checkpoint_path());
    return std::stol(ck.get("step")) == long(config.pretrain_steps) + config.steps;
  } catch (const std::exception&) {
    return false;
  }
}

// Small renders drawn larger (nearest neighbour, an integer factor) so that a picture sheet
// of a tiny scene stays legible.
Image8 enlarged(const Image8& im) {
  const int f = im.width >= 128 ? 1 : (127 + im.width) / std::max(1, im.width);
  if (f == 1) return im;
  Image8 out(im.width * f, im.height * f, im.channels);
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x)
      for (int c = 0; c < im.channels; ++c) out.at(x, y, c) = im.at(x / f, y / f, c);
  return out;
}

struct Evaluated {
  SceneResult result;
  Image8 picture;
};

Evaluated train_and_evaluate(Runtime& rt, const Planned& p, const std::string& run_dir, bool reuse, bool exact_motion) {
  Evaluated ev;
  SceneResult& r = ev.result;
  r.name = p.spec.name;
  r.set = p.spec.set;
  // As nova train: the scene with the run's factor and hold-out split (and its ground truth).
  Scene scene = load_training_scene(p.source, p.config, true);
  const std::string seconds_file = run_dir + "/train_seconds.txt";
  if (reuse && finished_run(run_dir, p.config, scene, exact_motion)) {
    r.status = "reused";
    try {
      r.train_s = std::stod(read_text(seconds_file));
    } catch (const std::exception&) {
    }
    std::cerr << "  reusing the finished run " << run_dir << "\n";
  } else {
    fs::remove_all(run_dir);
    std::cerr << "  training " << scene.name << ": " << scene.frames.size() << " frames at " << scene.frames[0].rgb.width
              << "x" << scene.frames[0].rgb.height << ", 1 + " << scene.num_objects << " NeRFs, preset "
              << p.config.preset << ", " << p.config.pretrain_steps << " + " << p.config.steps << " steps\n";
    const auto t0 = clock_type::now();
    Trainer trainer(rt, scene, p.config, run_dir);
    std::optional<SynthWorld> world;  // outlives the training that calls the hook
    if (exact_motion) {
      world.emplace(p.spec.preset, p.spec.seed);
      trainer.set_motion_start_hook([&](MotionStart& start) {
        start.rows = exact_motion_rows(scene, *world, start.rows);
        // Each box about the pivot of the rows it will be read with (the mean of their
        // translations), not of the alignment's, which can lie a radius or more away.
        const int F = static_cast<int>(scene.frames.size());
        for (size_t k = 0; k < start.radii.size(); ++k) {
          const std::array<float, 6> box =
              object_box_for(start.rows.data() + k * size_t(F) * 6, F, start.radii[k], trainer.geometry());
          std::copy(box.begin(), box.end(), start.boxes.begin() + long(k) * 6);
        }
      });
      write_atomically(run_dir + "/" + kExactMotionMarker, "started from the generator's exact motion (nova-bench accuracy --exact-motion)\n");
    }
    trainer.run([](const TrainProgress& pr) { std::cerr << "  " << progress_line(pr) << "\n"; });
    r.train_s = since(t0);
    write_atomically(seconds_file, num(r.train_s, 3) + "\n");
  }

  // As nova eval: the run as written (config.ini, checkpoint.bin), learnt blending for the
  // scene's views, hard blending for composition targets.
  const auto t0 = clock_type::now();
  const RunFiles files = RunFolder(run_dir).read();
  r.steps = std::stol(files.checkpoint.get("step"));
  ViewRenderer renderer(rt, files.config, ray_geometry(scene), files.checkpoint);
  std::vector<GroundTruthView> cam0, held;
  for (GroundTruthView& v : scene.gt_views) (v.kind == "cam0" ? cam0 : held).push_back(std::move(v));
  if (!p.spec.eval_split.empty()) {
    Scene split = load_training_scene(p.source, files.config, false, p.spec.eval_split);
    held = split_views(split, p.spec.eval_split);
  }
  // The picture: camera 0 at the first, middle and last time, else the first held-out view.
  const std::vector<GroundTruthView>& shown = cam0.empty() ? held : cam0;
  std::vector<size_t> picks;
  if (!shown.empty()) picks = cam0.empty() ? std::vector<size_t>{0} : std::vector<size_t>{0, shown.size() / 2, shown.size() - 1};
  picks.erase(std::unique(picks.begin(), picks.end()), picks.end());
  std::vector<Image8> tiles;
  std::vector<std::string> captions;
  const auto keep = [&](size_t i, const std::string& stem, const Image8& out) {
    if (std::find(picks.begin(), picks.end(), i) == picks.end()) return;
    const std::string what = cam0.empty() ? stem : "t = " + std::to_string(shown[i].time_index);
    tiles.push_back(enlarged(out));
    captions.push_back(what + " render");
    tiles.push_back(enlarged(shown[i].rgb));
    captions.push_back(what + " truth");
  };
  const auto score = [&](const std::vector<GroundTruthView>& views, const std::string& what, bool pictured) {
    const auto s = score_views(renderer, scene.num_objects, views, false, [&](size_t i, const std::string& stem, const Image8& o) {
      if (pictured) keep(i, stem, o);
      count_progress("  evaluated " + what + " views", i + 1, views.size());
    });
    return s;
  };
  const auto cam0_scores = score(cam0, "camera-0", true);
  const auto held_scores = score(held, p.spec.eval_split.empty() ? "held-out" : p.spec.eval_split, cam0.empty());
  const auto compose_scores = score_compose_targets(renderer, scene, true);
  r.eval_s = since(t0);
  if (!cam0_scores.empty()) {
    std::tie(r.cam0_psnr, r.cam0_ssim) = mean_scores(cam0_scores);
    std::tie(r.cam0_object_psnr, r.cam0_background_psnr) = mean_region_scores(cam0_scores);
    r.cam0_object_opacity = mean_object_opacity(cam0_scores);
  }
  if (!held_scores.empty()) {
    std::tie(r.heldout_psnr, r.heldout_ssim) = mean_scores(held_scores);
    std::tie(r.heldout_object_psnr, r.heldout_background_psnr) = mean_region_scores(held_scores);
    r.heldout_object_opacity = mean_object_opacity(held_scores);
  }
  if (!compose_scores.empty()) {
    r.compose_psnr = mean_scores(compose_scores).first;
    r.compose_object_psnr = mean_region_scores(compose_scores).first;
    r.compose_object_opacity = mean_object_opacity(compose_scores);
  }
  r.cam0_views = static_cast<int>(cam0_scores.size());
  r.heldout_views = static_cast<int>(held_scores.size());
  r.compose_views = static_cast<int>(compose_scores.size());
  if (!tiles.empty()) ev.picture = image_row(tiles, captions);
  return ev;
}

Image8 results_plot(const std::vector<SceneResult>& results, const std::string& config_text) {
  std::vector<BarGroup> bars, object_bars;
  std::vector<ScatterGroup> points;
  for (const std::string& set : kSetOrder) {
    BarGroup g{set, {}}, go{set, {}};
    ScatterGroup s{set, {}, {}};
    for (const SceneResult& r : results) {
      if (r.set != set) continue;
      g.bars.emplace_back(r.name, r.scored() ? r.psnr() : kNaN);
      go.bars.emplace_back(r.name, r.scored() ? r.object_psnr() : kNaN);
      if (r.scored()) {
        s.xy.emplace_back(r.train_s, r.psnr());
        s.names.push_back(r.name);
      }
    }
    if (g.bars.empty()) continue;
    bars.push_back(g);
    object_bars.push_back(go);
    points.push_back(s);
  }
  const Image8 objects = plot_bar_groups(
      object_bars, "PSNR inside the objects' masks (camera 0 at every time; real scenes: held-out views), " + config_text,
      "PSNR (dB)");
  const Image8 a = plot_bar_groups(bars, "PSNR of the whole frame, the same views", "PSNR (dB)");
  const Image8 b = plot_scatter(points, "PSNR against training time", "training time (s)", "PSNR (dB)");
  return stack_images({objects, a, b});
}

}  // namespace

int accuracy(const Args& raw_args) {
  std::vector<std::string> args = raw_args;
  const std::vector<std::string> sets = take_repeated(args, "set", "KEY=VALUE, a nova train option");
  const Options o(args, {{"scenes", "dev"}, {"out", "accuracy"}, {"preset", "quick"}, {"config", ""}, {"data", ""},
                         {"device", ""}, {"reuse", "off"}, {"exact-motion", "off"}, {"dry-run", "off"}});
  if (o.help()) {
    std::cout << kUsage;
    return 0;
  }
  const std::string out = [&] {
    std::string d = o.str("out");
    while (d.size() > 1 && d.back() == '/') d.pop_back();
    if (d.empty()) throw Error("--out must name a folder");
    return d;
  }();

  // The configuration, checked before anything is written: preset, then the config file (as
  // nova train: it names its own preset), then each scene's protocol, then --set.
  std::vector<std::pair<std::string, std::string>> overrides;
  for (const std::string& s : sets) {
    const size_t eq = s.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == s.size())
      throw Error("--set '" + s + "' is not KEY=VALUE (a nova train option, e.g. --set steps=1000)");
    std::string key = s.substr(0, eq);
    if (key.rfind("--", 0) == 0) key = key.substr(2);
    if (key == "preset") throw Error("--set '" + s + "': give the preset as --preset");
    bool known = false;
    for (const ConfigOption& c : config_options()) known = known || c.key == key;
    if (!known) throw Error("--set '" + s + "': '" + key + "' is not an option of nova train (nova train --help)");
    TrainConfig probe = preset_config("quick");
    try {
      set_config_value(probe, key, s.substr(eq + 1));
    } catch (const Error& e) {
      throw Error("--set '" + s + "': " + e.what());
    }
    overrides.emplace_back(key, s.substr(eq + 1));
  }
  TrainConfig base = preset_config(o.str("preset"));
  const std::string config_path = o.str("config");
  if (!config_path.empty()) {
    std::ifstream in(config_path);
    if (!in) throw Error("--config: file '" + config_path + "' cannot be read");
    std::stringstream text;
    text << in.rdbuf();
    std::vector<std::pair<std::string, std::string>> others;
    base = parse_config_text(text.str(), config_path, &others, ConfigFile::Partial);
    for (auto& [k, v] : others)
      if (k != "scene") throw Error(config_path + ": unknown option '" + k + "'");
  }

  const bool exact_motion = o.flag("exact-motion");
  std::vector<SceneSpec> specs = parse_scene_list(o.str("scenes"));
  const std::string data = data_folder(o.str("data"));
  std::vector<Planned> plan;
  std::vector<std::string> notes;
  for (const SceneSpec& s : specs) {
    Planned p{s, base, ""};
    try {
      if (s.synthetic) {
        check_synth_preset(s.preset);  // an unknown preset is an error now, not after other scenes trained
        p.source = out + "/scenes/" + s.dir_name();
      } else {
        const std::string dir = data.empty() ? "" : data + "/" + s.folder;
        if (dir.empty() || !fs::is_directory(dir)) {
          const std::string why = data.empty() ? "no data folder found (pass --data DIR)"
                                                : "'" + dir + "' does not exist (--data " + data + ")";
          if (s.named) throw Error(why);
          notes.push_back("skipped " + s.name + ": " + why);
          continue;
        }
        p.source = dir;
      }
      for (const auto& [k, v] : s.protocol) set_config_value(p.config, k, v);
      for (const auto& [k, v] : overrides) set_config_value(p.config, k, v);
      validate(p.config);
      if (exact_motion && !(s.synthetic && s.preset == "family"))
        throw Error("--exact-motion needs family:SEED scenes, whose generator knows the objects' motion");
      if (exact_motion && p.config.field.motion != ObjectMotion::Rigid)
        throw Error("--exact-motion starts rigid objects; it needs 'object-motion rigid' (object-motion is " +
                    std::string(object_motion_name(p.config.field.motion)) + ")");
    } catch (const Error& e) {
      throw Error("scene '" + s.name + "': " + e.what());
    }
    plan.push_back(std::move(p));
  }
  if (plan.empty()) throw Error("--scenes '" + o.str("scenes") + "': no scene left to run (" + notes.front() + ")");

  std::string config_text = "preset " + base.preset;
  if (!config_path.empty()) config_text += ", --config " + config_path;
  for (const std::string& s : sets) config_text += ", " + s;
  if (exact_motion) config_text += ", --exact-motion";
  const DeviceInfo device = select_device(o.str("device"));
  std::cout << "nova-bench accuracy: " << plan.size() << " scene" << (plan.size() > 1 ? "s" : "") << ", " << config_text
            << ", device " << device.name << "\n";
  for (const Planned& p : plan) {
    std::cout << "  " << std::left << std::setw(20) << p.spec.name << " " << std::setw(10) << p.spec.set << " " << p.source << ", "
              << p.config.pretrain_steps << " + " << p.config.steps << " steps";
    for (const auto& [k, v] : p.spec.protocol) std::cout << ", --" << k << " " << v;
    if (!p.spec.eval_split.empty()) std::cout << ", scored on its " << p.spec.eval_split << " split";
    std::cout << "\n";
  }
  for (const std::string& n : notes) std::cout << "  note: " << n << "\n";
  if (o.flag("dry-run")) return 0;

  for (const char* d : {"scenes", "runs", "pictures"}) fs::create_directories(out + "/" + d);
  Runtime rt(device, false);
  std::vector<SceneResult> results;
  const auto start = clock_type::now();
  int failures = 0;
  for (size_t i = 0; i < plan.size(); ++i) {
    const Planned& p = plan[i];
    std::cerr << "[" << i + 1 << "/" << plan.size() << "] " << p.spec.name << " (" << p.spec.set << ")";
    if (i > 0) {
      const double done = since(start);
      std::cerr << "  elapsed " << clock_text(done) << ", eta " << clock_text(done / i * (plan.size() - i));
    }
    std::cerr << "\n";
    try {
      if (p.spec.synthetic) ensure_synthetic(p.spec, p.source);
      Evaluated ev = train_and_evaluate(rt, p, out + "/runs/" + p.spec.dir_name(), o.flag("reuse"), exact_motion);
      if (!ev.picture.empty()) write_png_atomically(out + "/pictures/" + p.spec.dir_name() + ".png", ev.picture);
      const SceneResult& r = ev.result;
      // Where the views' objects regions are known, the PSNR inside them first, then the frame's.
      const auto scores = [](double object, double frame) {
        return std::isfinite(object) ? "objects " + num_or(object, 2) + " / frame " + num_or(frame, 2)
                                     : num_or(frame, 2);
      };
      std::cerr << "  " << r.name << ": " << r.steps << " steps, train " << num_or(r.train_s, 1) << " s, eval "
                << num_or(r.eval_s, 1) << " s; PSNR camera 0 " << scores(r.cam0_object_psnr, r.cam0_psnr)
                << ", held-out " << scores(r.heldout_object_psnr, r.heldout_psnr) << ", composition "
                << scores(r.compose_object_psnr, r.compose_psnr) << "\n";
      results.push_back(std::move(ev.result));
    } catch (const std::exception& e) {
      // One failing scene does not stop the rest; the exit code says so.
      std::cerr << "nova-bench accuracy: scene '" << p.spec.name << "' failed: " << e.what() << "\n";
      SceneResult r;
      r.name = p.spec.name;
      r.set = p.spec.set;
      r.status = std::string("failed: ") + e.what();
      results.push_back(r);
      ++failures;
    }
  }

  const std::vector<SetSummary> summaries = aggregate(results);
  std::vector<std::pair<std::string, std::string>> settings = {{"preset", base.preset}, {"config", config_path}};
  for (const auto& [k, v] : overrides) settings.emplace_back("set " + k, v);
  if (exact_motion) settings.emplace_back("exact-motion", "on");
  settings.emplace_back("device", device.name);
  write_atomically(out + "/accuracy.csv", csv_text(results, summaries));
  write_atomically(out + "/accuracy.json", json_text(settings, results, summaries));
  write_png_atomically(out + "/accuracy.png", results_plot(results, config_text));
  std::cout << "\n" << table_text(results, summaries);
  for (const std::string& n : notes) std::cout << n << "\n";
  std::cout << "wrote " << out << "/accuracy.csv, " << out << "/accuracy.json, " << out << "/accuracy.png and "
            << out << "/pictures/ (" << clock_text(since(start)) << ")\n";
  return failures > 0 ? kExitInternal : 0;
}

}  // namespace nova::bench

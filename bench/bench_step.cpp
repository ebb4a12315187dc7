// nova-bench step: the training step itself, per preset (quick, reference), phase (static
// pretraining, joint) and number of object NeRFs K, on a scene of the user's: seconds per
// step and rays/s over timed steps after a warm-up, the device memory of the step (memory
// plan, parameters, gradients, Adam) and the process's peak RSS, then a per-op table from a
// few profiled steps. Occupancy skipping is off (its warm-up would need a trained model): the
// numbers are those of the dense step, the most a step costs. With --run RUN the bench instead
// continues a trained run (its configuration, weights, occupancy grids and phase): the step a
// long training takes once its grids skip empty space. Built only with nova_io.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "bench.hpp"
#include "nova/data/scene_io.hpp"
#include "nova/train/run_folder.hpp"
#include "nova/runtime/runtime.hpp"
#include "nova/train/train_config.hpp"
#include "nova/train/trainer.hpp"
#include "options.hpp"
#include "torch_peer.hpp"

namespace nova::bench {
namespace {

namespace fs = std::filesystem;

// The scene with only its first K objects: the others' pixels join the background mask.
Scene with_objects(Scene scene, int K) {
  for (Frame& f : scene.frames) {
    for (size_t k = static_cast<size_t>(K) + 1; k < f.masks.size(); ++k)
      for (size_t i = 0; i < f.masks[0].data.size(); ++i)
        f.masks[0].data[i] = std::max(f.masks[0].data[i], f.masks[k].data[i]);
    f.masks.resize(static_cast<size_t>(K) + 1);
  }
  scene.num_objects = K;
  return scene;
}

double peak_rss_mb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0;  // Linux: kilobytes
}

struct Row {
  std::string preset, phase;
  int objects = 0, rays = 0, samples = 0;
  double seconds = 0, device_mb = 0, rss_mb = 0;
  double torch_seconds = 0;  // PyTorch's step of the same MLPs alone (0: not compared)
};

// The MLPs of a step in PyTorch: the preset's static trunk (its encoded input, depth x width,
// skip, 4 outputs) at rays x samples rows for each of the step's NeRFs, as one batch (the same
// FLOPs as one network each). Null where `python` is empty or has no torch (why says so).
std::unique_ptr<TorchPeer> torch_for(const std::string& python, const TrainConfig& c, int nerfs, std::string& why) {
  if (python.empty()) {
    why = "--torch off, or no /usr/bin/python3";
    return nullptr;
  }
  const FieldConfig& f = c.field;
  TorchMlpShape shape;
  shape.batch = static_cast<size_t>(c.rays) * static_cast<size_t>(c.samples) * static_cast<size_t>(nerfs);
  shape.inputs = f.encoding == Encoding::HashGrid ? f.hash.outputs() : 3 + 6 * f.pos_freqs;
  shape.width = f.width;
  shape.depth = f.depth;
  shape.skip = f.skip < f.depth ? f.skip : -1;
  return TorchPeer::start(python, shape, why);
}

// Seconds per step of `steps` steps after `warmup` untimed ones, from the trainer's current step.
// The last step's progress report comes after the device has finished it and before run()
// writes its closing checkpoint, which is no part of a step.
// With a PyTorch peer the trainer must report every step (log_every 1): each report ends one
// nova step (its device work done), the peer then runs one step of its own, and both times
// are medians; `torch_seconds` gets the peer's.
double time_steps(Runtime& rt, Trainer& t, long warmup, long steps, TorchPeer* peer = nullptr,
                  double* torch_seconds = nullptr) {
  t.run({}, t.step() + warmup);
  rt.finish();
  using clock = std::chrono::steady_clock;
  auto a = clock::now();
  if (!peer) {
    auto b = a;
    t.run([&](const TrainProgress&) { b = clock::now(); }, t.step() + steps);
    return std::chrono::duration<double>(b - a).count() / static_cast<double>(steps);
  }
  std::vector<double> nova_s, torch_s;
  t.run(
      [&](const TrainProgress&) {
        nova_s.push_back(std::chrono::duration<double>(clock::now() - a).count());
        torch_s.push_back(peer->step());
        a = clock::now();
      },
      t.step() + steps);
  *torch_seconds = median(torch_s);
  return median(nova_s);
}

// The per-op table of `steps` profiled steps after `warmup` untimed ones (their kernel builds),
// from the trainer's current step; the trainer profiles (set_profile before its executor).
std::string profiled_steps(Trainer& t, long warmup, long steps) {
  t.run({}, t.step() + warmup);
  t.reset_profile();
  t.run({}, t.step() + steps);
  return t.profile_table();
}

void print_row(const Row& r) {
  std::cout << std::left << std::setw(10) << r.preset << std::setw(9) << r.phase << "K=" << std::setw(3) << r.objects
            << std::right << std::fixed << std::setprecision(3) << std::setw(9) << r.seconds << " s/step"
            << std::setprecision(0) << std::setw(9) << r.rays / r.seconds << " rays/s" << std::setw(8)
            << r.device_mb << " MB device" << std::setw(7) << r.rss_mb << " MB peak RSS";
  if (r.torch_seconds > 0)
    std::cout << std::setprecision(3) << "   PyTorch, its MLPs alone: " << r.torch_seconds << " s/step (nova / PyTorch "
              << std::setprecision(2) << r.torch_seconds / r.seconds << ")";
  std::cout << std::endl;
}

void write_csv(const std::vector<Row>& rows, const std::string& out, const std::string& profiles) {
  std::ostringstream csv;
  csv << "preset,phase,objects,rays,samples,seconds_per_step,rays_per_second,device_mb,peak_rss_mb,"
         "torch_mlps_seconds_per_step\n";
  for (const Row& r : rows) {
    csv << r.preset << "," << r.phase << "," << r.objects << "," << r.rays << "," << r.samples << "," << r.seconds
        << "," << r.rays / r.seconds << "," << r.device_mb << "," << r.rss_mb << ",";
    if (r.torch_seconds > 0) csv << r.torch_seconds;
    csv << "\n";
  }
  std::cout << "\n" << csv.str() << profiles;
  if (!out.empty()) {
    const std::string tmp = out + ".tmp";
    std::ofstream(tmp) << csv.str();
    fs::rename(tmp, out);
    std::cout << "\nwrote " << out << "\n";
  }
}

// A copy of the run's config.ini and checkpoint.bin in `dir`, resumed: every later step of it
// is the step the run would take next (its own randomness, grids and their updates).
std::unique_ptr<Trainer> resumed_copy(Runtime& rt, const Scene& scene, TrainConfig c, const RunFolder& run,
                                      const fs::path& dir, long more_steps, bool profile = false,
                                      int log_every = 1000000) {
  fs::create_directories(dir);
  fs::copy_file(run.config_path(), dir / kConfigFile, fs::copy_options::overwrite_existing);
  fs::copy_file(run.checkpoint_path(), dir / kCheckpointFile, fs::copy_options::overwrite_existing);
  c.steps += static_cast<int>(more_steps);  // room to go on past the run's end
  c.log_every = log_every;
  c.checkpoint_every = 1000000;
  auto t = std::make_unique<Trainer>(rt, scene, c, dir.string());
  t->set_profile(profile);  // before resume(), which builds the step's executor
  t->resume();
  return t;
}

int step_of_run(const Options& o, long steps, long warmup, long profile_steps) {
  const RunFolder run(o.str("run"));
  const RunFiles files = run.read();
  const std::string scene_dir = o.str("scene").empty() ? files.scene : o.str("scene");
  if (scene_dir.empty()) throw Error("--run: '" + run.config_path() + "' names no scene: pass --scene");
  LoadOptions lo;
  lo.factor = files.config.factor;
  lo.static_only = files.config.static_only;
  lo.load_gt = false;
  const Scene scene = load_scene(scene_dir, lo);
  const ScratchDir scratch("step");
  Runtime rt(select_device(o.str("device")), false);
  Runtime prt(rt.info(), true);
  const long more = warmup + std::max(steps, profile_steps);
  Row r;
  std::ostringstream profiles;
  {
    const long at = std::stol(files.checkpoint.get("step"));
    const bool joint = at >= files.config.pretrain_steps && scene.num_objects > 0;
    std::string why;
    auto peer = torch_for(torch_python(o.str("torch")), files.config, 1 + (joint ? scene.num_objects : 0), why);
    auto t = resumed_copy(rt, scene, files.config, run, scratch / "run", more, false, peer ? 1 : 1000000);
    std::cout << "device " << rt.info().name << "; run " << run.dir() << " (preset " << files.config.preset
              << ", step " << t->step() << ", " << (joint ? "joint" : "pretraining") << ") on " << scene_dir << "; "
              << warmup << " warm-up + " << steps << " timed steps, skipping as the run's grids say\n\n";
    if (!peer) std::cout << "PyTorch: not compared (" << why << ")\n";
    r = Row{files.config.preset, joint ? "joint" : "pretrain", joint ? scene.num_objects : 0, files.config.rays,
            files.config.samples};
    r.seconds = time_steps(rt, *t, warmup, steps, peer.get(), &r.torch_seconds);
    r.device_mb = static_cast<double>(t->device_bytes()) / (1024.0 * 1024.0);
  }
  r.rss_mb = peak_rss_mb();
  print_row(r);
  if (profile_steps > 0) {
    auto t = resumed_copy(prt, scene, files.config, run, scratch / "profile", more, true);
    profiles << "\n" << r.preset << " " << r.phase << " (" << profile_steps << " profiled steps)\n"
             << profiled_steps(*t, warmup, profile_steps);
  }
  write_csv({r}, o.str("out"), profiles.str());
  return 0;
}

}  // namespace

int step(const Args& args) {
  const Options o(args, {{"scene", ""}, {"presets", "quick,reference"}, {"objects", "1,2"}, {"steps", "5"},
                         {"warmup", "2"}, {"profile-steps", "2"}, {"factor", "1"}, {"device", ""},
                         {"out", ""}, {"run", ""}, {"torch", "auto"}});
  if (o.help()) {
    std::cout << o.usage("nova-bench step")
              << "\nSeconds per training step (occupancy skipping off: the dense step), device memory and peak\n"
                 "RSS, per preset and phase, then a per-op profile.\n\n"
                 "--scene: the scene folder to step on (required unless --run)\n"
                 "--presets: comma list of presets (quick, reference)\n"
                 "--objects: numbers of object NeRFs K (the scene's first K)\n"
                 "--steps, --warmup: timed steps, and untimed steps before them (kernel builds)\n"
                 "--profile-steps: steps of the per-op profile (0: none)\n"
                 "--factor: image downscale factor of the scene\n"
                 "--out: also write the table as CSV here\n"
                 "--device: OpenCL device, as nova's --device\n"
              << "--run RUN: continue a trained run instead (its config, weights, grids and phase; --scene\n"
                 "  defaults to the run's scene; --presets, --objects and --factor do not apply)\n"
              << "--torch: auto (/usr/bin/python3, when it has torch), off, or an interpreter's path: each row's\n"
                 "  MLPs alone (the preset's trunk at the step's rows of every NeRF) in PyTorch, alternating\n";
    return 0;
  }
  const long steps = o.integer("steps"), warmup = o.integer("warmup"), profile_steps = o.integer("profile-steps");
  if (steps < 1 || warmup < 0 || profile_steps < 0) throw Error("--steps must be >= 1, --warmup and --profile-steps >= 0");
  if (!o.str("run").empty()) return step_of_run(o, steps, warmup, profile_steps);
  if (o.str("scene").empty()) throw Error("--scene SCENE is required (e.g. the default synthetic scene of nova synth)");
  LoadOptions lo;
  lo.factor = static_cast<int>(o.integer("factor"));
  lo.load_gt = false;
  const Scene scene = load_scene(o.str("scene"), lo);
  std::vector<int> objects;
  for (long k : o.integers("objects")) {
    if (k < 1 || k > scene.num_objects)
      throw Error("--objects: " + std::to_string(k) + " object NeRFs, but the scene has " +
                  std::to_string(scene.num_objects));
    objects.push_back(static_cast<int>(k));
  }
  const std::vector<std::string> preset_list = o.strings("presets");
  std::vector<TrainConfig> presets;
  for (const std::string& p : preset_list) presets.push_back(preset_config(p));

  const ScratchDir scratch("step");

  Runtime rt(select_device(o.str("device")), false);
  Runtime prt(rt.info(), true);  // a profiling runtime for the per-op tables
  std::cout << "device " << rt.info().name << "; scene " << o.str("scene") << " (" << scene.frames[0].camera.width
            << "x" << scene.frames[0].camera.height << ", " << scene.num_objects << " objects); " << warmup
            << " warm-up + " << steps << " timed steps per row, occupancy skipping off (the dense step)\n\n";
  std::vector<Row> rows;
  std::ostringstream profiles;
  const std::string python = torch_python(o.str("torch"));
  bool told_torch = false;
  for (size_t pi = 0; pi < presets.size(); ++pi)
    for (const bool joint : {false, true})
      for (int K : objects) {
        if (!joint && K != objects.front()) continue;  // pretraining has no object NeRFs
        TrainConfig c = presets[pi];
        c.occupancy = false;
        const int total = static_cast<int>(warmup + std::max(steps, profile_steps));
        c.pretrain_steps = joint ? 0 : total;
        c.steps = joint ? total : 0;
        c.log_every = 1000000;
        c.checkpoint_every = 1000000;
        const Scene s = with_objects(scene, K);
        Row r;
        r.preset = preset_list[pi];
        r.phase = joint ? "joint" : "pretrain";
        r.objects = joint ? K : 0;
        r.rays = c.rays;
        r.samples = c.samples;
        {
          std::string why;
          auto peer = torch_for(python, c, 1 + r.objects, why);
          if (!peer && !told_torch) std::cout << "PyTorch: not compared (" << why << ")\n";
          told_torch = true;
          TrainConfig timed = c;
          if (peer) timed.log_every = 1;  // a report after every step, where PyTorch takes its turn
          Trainer t(rt, s, timed, (scratch / "run").string());
          r.seconds = time_steps(rt, t, warmup, steps, peer.get(), &r.torch_seconds);
          r.device_mb = static_cast<double>(t.device_bytes()) / (1024.0 * 1024.0);
        }
        r.rss_mb = peak_rss_mb();
        if (profile_steps > 0) {
          Trainer t(prt, s, c, (scratch / "profile").string());
          t.set_profile(true);
          profiles << "\n" << r.preset << " " << r.phase << (joint ? " K=" + std::to_string(K) : std::string())
                   << " (" << profile_steps << " profiled steps)\n" << profiled_steps(t, warmup, profile_steps);
        }
        rows.push_back(r);
        print_row(r);
      }
  write_csv(rows, o.str("out"), profiles.str());
  return 0;
}

}  // namespace nova::bench

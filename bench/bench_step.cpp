// nova-bench step: the training step itself, per preset (quick, reference), phase (static
// pretraining, joint) and number of object NeRFs K, on a scene of the user's: seconds per
// step and rays/s over timed steps after a warm-up, the device memory of the step (memory
// plan, parameters, gradients, Adam), the process's peak RSS and the commands each step puts on
// the queue (kernels, CLBlast calls, host calls, memory commands: Runtime::commands), then a
// per-op table from a few profiled steps. Occupancy skipping is off (its warm-up would need a trained model): the
// numbers are those of the dense step, the most a step costs. With --run RUN the bench instead
// continues a trained run (its configuration, weights, occupancy grids and phase): the step a
// long training takes once its grids skip empty space. With --anchor DIR it alternates nova's
// steps with the original NOVA code's (bench/anchor_run.hpp) on the same scene and networks and
// prints the ratios; nova's side is the dense step, or for a phase a trained run given with
// --run is in, that run's next steps. Built only with nova_io.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>

#include "bench.hpp"
#include "nova/data/scene_io.hpp"
#include "nova/train/run_folder.hpp"
#include "nova/runtime/runtime.hpp"
#include "nova/train/train_config.hpp"
#include "nova/train/trainer.hpp"
#include "options.hpp"
#include "anchor_compare.hpp"
#include "anchor_run.hpp"
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
  CommandCounts commands{};  // per timed step (rounded down)
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
// With a PyTorch peer or `per_step` the trainer must report every step (log_every 1): each
// report ends one nova step (its device work done), the peer then runs one step of its own,
// and the times are medians; `torch_seconds` gets the peer's, `per_step` every timed step's.
double time_steps(Runtime& rt, Trainer& t, long warmup, long steps, TorchPeer* peer = nullptr,
                  double* torch_seconds = nullptr, std::vector<double>* per_step = nullptr,
                  CommandCounts* commands = nullptr) {
  t.run({}, t.step() + warmup);
  rt.finish();
  rt.reset_commands();
  const auto per_step_commands = [&] {
    if (!commands) return;
    const CommandCounts& c = rt.commands();
    const auto n = static_cast<size_t>(steps);
    *commands = {c.kernels / n, c.library / n, c.host / n, c.memory / n};
  };
  using clock = std::chrono::steady_clock;
  auto a = clock::now();
  if (!peer && !per_step) {
    auto b = a;
    t.run([&](const TrainProgress&) { b = clock::now(); }, t.step() + steps);
    per_step_commands();
    return std::chrono::duration<double>(b - a).count() / static_cast<double>(steps);
  }
  std::vector<double> nova_s, torch_s;
  t.run(
      [&](const TrainProgress&) {
        nova_s.push_back(std::chrono::duration<double>(clock::now() - a).count());
        if (peer) torch_s.push_back(peer->step());
        a = clock::now();
      },
      t.step() + steps);
  per_step_commands();
  if (peer) *torch_seconds = median(torch_s);
  if (per_step) *per_step = nova_s;
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
            << r.device_mb << " MB device" << std::setw(7) << r.rss_mb << " MB peak RSS" << std::setw(6)
            << r.commands.total() << " commands";
  if (r.torch_seconds > 0)
    std::cout << std::setprecision(3) << "   PyTorch, its MLPs alone: " << r.torch_seconds << " s/step (nova / PyTorch "
              << std::setprecision(2) << r.torch_seconds / r.seconds << ")";
  std::cout << std::endl;
}

void write_csv(const std::vector<Row>& rows, const std::string& out, const std::string& profiles) {
  std::ostringstream csv;
  csv << "preset,phase,objects,rays,samples,seconds_per_step,rays_per_second,device_mb,peak_rss_mb,"
         "torch_mlps_seconds_per_step,kernels_per_step,clblast_calls_per_step,host_calls_per_step,"
         "memory_commands_per_step\n";
  for (const Row& r : rows) {
    csv << r.preset << "," << r.phase << "," << r.objects << "," << r.rays << "," << r.samples << "," << r.seconds
        << "," << r.rays / r.seconds << "," << r.device_mb << "," << r.rss_mb << ",";
    if (r.torch_seconds > 0) csv << r.torch_seconds;
    csv << "," << r.commands.kernels << "," << r.commands.library << "," << r.commands.host << ","
        << r.commands.memory << "\n";
  }
  std::cout << "\n" << csv.str() << profiles;
  if (!out.empty()) {
    const std::string tmp = out + ".tmp";
    std::ofstream(tmp) << csv.str();
    fs::rename(tmp, out);
    std::cout << "\nwrote " << out << "\n";
  }
}

// Whether a run's checkpoint is in the joint phase (a run of pretraining alone is not, at its end too).
bool joint_checkpoint(const RunFiles& files) { return files.checkpoint.get("phase") == "joint"; }

// A copy of the run's config.ini and checkpoint.bin in `dir`, resumed: every later step of it
// is the step the run would take next (its own randomness, grids and their updates), in the
// checkpoint's phase.
std::unique_ptr<Trainer> resumed_copy(Runtime& rt, const Scene& scene, const RunFiles& files, const RunFolder& run,
                                      const fs::path& dir, long more_steps, bool profile = false,
                                      int log_every = 1000000) {
  fs::create_directories(dir);
  fs::copy_file(run.config_path(), dir / kConfigFile, fs::copy_options::overwrite_existing);
  fs::copy_file(run.checkpoint_path(), dir / kCheckpointFile, fs::copy_options::overwrite_existing);
  TrainConfig c = files.config;
  // Room to go on past the run's end in its own phase: a run that stopped in or at the end of
  // pretraining goes on pretraining.
  (joint_checkpoint(files) ? c.steps : c.pretrain_steps) += static_cast<int>(more_steps);
  c.log_every = log_every;
  c.checkpoint_every = 1000000;
  auto t = std::make_unique<Trainer>(rt, scene, c, dir.string());
  t->set_profile(profile);  // before resume(), which builds the step's executor
  t->resume();
  return t;
}

// A trained run, its files and the scene it trains on (--scene, else the run's own).
struct TrainedRun {
  RunFolder run;
  RunFiles files;
  std::string scene_dir;
  Scene scene;
};

TrainedRun trained_run(const std::string& dir, const std::string& scene_option) {
  TrainedRun t{RunFolder(dir), {}, {}, {}};
  t.files = t.run.read();
  t.scene_dir = scene_option.empty() ? t.files.scene : scene_option;
  if (t.scene_dir.empty()) throw Error("--run: '" + t.run.config_path() + "' names no scene: pass --scene");
  LoadOptions lo;
  lo.factor = t.files.config.factor;
  lo.static_only = t.files.config.static_only;
  lo.load_gt = false;
  t.scene = load_scene(t.scene_dir, lo);
  return t;
}

// A phase's row continued from a trained run: `peer` (may be null) times PyTorch's MLPs
// beside every step, `per_step` (may be null) gets every timed step's seconds.
Row run_row(Runtime& rt, const TrainedRun& tr, long warmup, long steps, const fs::path& dir, TorchPeer* peer,
            std::vector<double>* per_step) {
  const bool joint = joint_checkpoint(tr.files);
  auto t = resumed_copy(rt, tr.scene, tr.files, tr.run, dir, warmup + steps, false, peer || per_step ? 1 : 1000000);
  Row r{tr.files.config.preset, joint ? "joint" : "pretrain", joint ? tr.scene.num_objects : 0, tr.files.config.rays,
        tr.files.config.samples};
  r.seconds = time_steps(rt, *t, warmup, steps, peer, &r.torch_seconds, per_step, &r.commands);
  r.device_mb = static_cast<double>(t->device_bytes()) / (1024.0 * 1024.0);
  r.rss_mb = peak_rss_mb();
  return r;
}

// The per-op table of a trained run's next `profile_steps` steps, under `title`.
std::string run_profile(Runtime& prt, const TrainedRun& tr, const std::string& title, long warmup, long profile_steps,
                        const fs::path& dir) {
  auto t = resumed_copy(prt, tr.scene, tr.files, tr.run, dir, warmup + profile_steps, true);
  return "\n" + title + " (" + std::to_string(profile_steps) + " profiled steps)\n" +
         profiled_steps(*t, warmup, profile_steps);
}

int step_of_run(const Options& o, long steps, long warmup, long profile_steps) {
  const TrainedRun tr = trained_run(o.str("run"), o.str("scene"));
  const ScratchDir scratch("step");
  Runtime rt(select_device(o.str("device")), false);
  Runtime prt(rt.info(), true);
  const bool joint = joint_checkpoint(tr.files);
  std::string why;
  auto peer = torch_for(torch_python(o.str("torch")), tr.files.config, 1 + (joint ? tr.scene.num_objects : 0), why);
  std::cout << "device " << rt.info().name << "; run " << tr.run.dir() << " (preset " << tr.files.config.preset << ", step "
            << tr.files.checkpoint.get("step") << ", " << (joint ? "joint" : "pretraining") << ") on " << tr.scene_dir
            << "; " << warmup << " warm-up + " << steps << " timed steps, skipping as the run's grids say\n\n";
  if (!peer) std::cout << "PyTorch: not compared (" << why << ")\n";
  const Row r = run_row(rt, tr, warmup, steps, scratch / "run", peer.get(), nullptr);
  print_row(r);
  const std::string profiles =
      profile_steps > 0
          ? run_profile(prt, tr, r.preset + " " + r.phase, warmup, profile_steps, scratch / "profile")
          : std::string();
  write_csv({r}, o.str("out"), profiles);
  return 0;
}

// The dense step's configuration for one phase: `total` steps of it and nothing else.
TrainConfig phase_config(TrainConfig c, bool joint, long total) {
  c.occupancy = false;
  c.pretrain_steps = joint ? 0 : static_cast<int>(total);
  c.steps = joint ? static_cast<int>(total) : 0;
  c.log_every = 1000000;
  c.checkpoint_every = 1000000;
  return c;
}

// The timed row of one preset, phase and object count, on a fresh trainer. `python` (empty:
// none) times PyTorch's MLPs beside it; `per_step` gets every timed step's seconds.
Row time_row(Runtime& rt, const Scene& s, const TrainConfig& preset, const std::string& name, bool joint, int K,
             long warmup, long steps, const fs::path& dir, const std::string& python, bool& told_torch,
             std::vector<double>* per_step = nullptr) {
  TrainConfig c = phase_config(preset, joint, warmup + steps);
  Row r{name, joint ? "joint" : "pretrain", joint ? K : 0, c.rays, c.samples};
  std::string why;
  auto peer = torch_for(python, c, 1 + r.objects, why);
  if (!peer && !told_torch) std::cout << "PyTorch: not compared (" << why << ")\n";
  told_torch = true;
  if (peer || per_step) c.log_every = 1;  // a report after every step, where PyTorch takes its turn
  Trainer t(rt, s, c, dir.string());
  r.seconds = time_steps(rt, t, warmup, steps, peer.get(), &r.torch_seconds, per_step, &r.commands);
  r.device_mb = static_cast<double>(t.device_bytes()) / (1024.0 * 1024.0);
  r.rss_mb = peak_rss_mb();
  return r;
}

std::string profile_of(Runtime& prt, const Scene& s, const TrainConfig& preset, const std::string& name, bool joint,
                       int K, long warmup, long profile_steps, const fs::path& dir) {
  Trainer t(prt, s, phase_config(preset, joint, warmup + profile_steps), dir.string());
  t.set_profile(true);
  return "\n" + name + " " + (joint ? "joint K=" + std::to_string(K) : std::string("pretrain")) + " (" +
         std::to_string(profile_steps) + " profiled steps)\n" + profiled_steps(t, warmup, profile_steps);
}

// The run of `runs` in the joint phase (or in pretraining), or null.
const TrainedRun* run_in_phase(const std::vector<TrainedRun>& runs, bool joint) {
  for (const TrainedRun& r : runs)
    if (joint_checkpoint(r.files) == joint) return &r;
  return nullptr;
}

// nova's pretraining and joint rows, then one run of the NOVA code, `rounds` times; then the
// comparison and one profile of each of nova's phases (after the rounds: no part of a timing).
// A phase one of `runs` is in continues that run, in the rounds and in the profile.
int beside_anchor(const Options& o, const Scene& scene, const TrainConfig& preset, const std::string& name, int K,
                  long warmup, long steps, long profile_steps, AnchorRun anchor, const ScratchDir& scratch,
                  const std::vector<TrainedRun>& runs) {
  const long rounds = o.integer("rounds");
  Runtime rt(select_device(o.str("device")), false);
  anchor.cpu = (rt.info().type & CL_DEVICE_TYPE_CPU) != 0;
  anchor.pre_steps = anchor.joint_steps = static_cast<int>(warmup + steps);
  anchor.skip = static_cast<int>(warmup);
  anchor = anchor.resolve();
  std::cout << "device " << rt.info().name << "; scene " << o.str("scene") << " (" << scene.frames[0].camera.width << "x"
            << scene.frames[0].camera.height << ", K=" << K << ", preset " << name << "); " << rounds
            << " rounds, each nova's " << warmup << " warm-up + " << steps
            << " timed steps per phase, then the NOVA code: " << anchor.describe() << "\n";
  for (const bool joint : {false, true}) {
    const TrainedRun* r = run_in_phase(runs, joint);
    std::cout << "nova's " << (joint ? "joint" : "pretraining") << " steps: ";
    if (r)
      std::cout << "continuing run " << r->run.dir() << " from step " << r->files.checkpoint.get("step")
                << " (skipping empty space as its grids say)\n";
    else
      std::cout << "the dense step (no empty-space skipping)\n";
  }
  std::cout << "\n";
  const Scene s = with_objects(scene, K);
  const std::string python = torch_python(o.str("torch"));
  bool told_torch = false;
  std::vector<AnchorRound> done;
  std::vector<Row> rows;
  for (long round = 1; round <= rounds; ++round) {
    AnchorRound a;
    for (const bool joint : {false, true}) {
      std::vector<double> each;
      const TrainedRun* from = run_in_phase(runs, joint);
      rows.push_back(from ? run_row(rt, *from, warmup, steps, scratch / "run", nullptr, &each)
                          : time_row(rt, s, preset, name, joint, K, warmup, steps, scratch / "run", python, told_torch,
                                     &each));
      (joint ? a.nova.joint : a.nova.pretrain) = median(each);
      print_row(rows.back());
    }
    anchor.out = scratch / ("anchor-" + std::to_string(round));
    AnchorSteps ref = run_anchor(anchor);
    a.anchor = {median(ref.pretrain), median(ref.joint)};
    std::cout << "NOVA code, round " << round << ": pretraining " << std::fixed << std::setprecision(3)
              << a.anchor.pretrain << " s/step (" << ref.pretrain.size() << " timed), joint " << a.anchor.joint
              << " s/step (" << ref.joint.size() << " timed, " << ref.joint_novel_view << " novel-view)";
    if (!ref.end.empty())
      std::cout << "; torch " << ref.end["torch"] << ", " << ref.end["threads"] << " threads, " << ref.end["device"];
    std::cout << std::endl;
    done.push_back(a);
  }
  print_anchor_comparison(done, std::cout);
  std::ostringstream profiles;
  if (profile_steps > 0) {
    Runtime prt(rt.info(), true);
    for (const bool joint : {false, true}) {
      const TrainedRun* from = run_in_phase(runs, joint);
      if (!from) {
        profiles << profile_of(prt, s, preset, name, joint, K, warmup, profile_steps, scratch / "profile");
        continue;
      }
      profiles << run_profile(prt, *from,
                              name + " " + (joint ? "joint K=" + std::to_string(K) : std::string("pretrain")) +
                                  ", continuing " + from->run.dir(),
                              warmup, profile_steps, scratch / "profile");
    }
  }
  std::cout << "\n" << anchor_csv(done) << profiles.str();
  if (!o.str("out").empty()) {
    const std::string out = o.str("out"), tmp = out + ".tmp";
    std::ofstream(tmp) << anchor_csv(done);
    fs::rename(tmp, out);
    std::cout << "\nwrote " << out << "\n";
  }
  return 0;
}

// With --anchor DIR the options default to the NOVA code's scene, networks and a short run.
std::map<std::string, std::string> step_defaults(const Args& args) {
  std::map<std::string, std::string> d = {
      {"scene", ""},        {"presets", "quick,reference"}, {"objects", "1,2"}, {"steps", "5"},
      {"warmup", "2"},      {"profile-steps", "2"},         {"factor", "1"},    {"device", ""},
      {"out", ""},          {"run", ""},                    {"torch", "auto"},  {"anchor", ""},
      {"rounds", "2"},      {"anchor-python", "auto"}};
  const auto a = std::find(args.begin(), args.end(), "--anchor");
  if (a != args.end() && a + 1 != args.end()) {
    d["scene"] = (fs::path(a[1]) / "data" / "Balloon1").string();
    d["factor"] = "2";
    d["presets"] = "reference";
    d["objects"] = "1";
    d["steps"] = "3";
    d["warmup"] = "1";
    d["torch"] = "off";  // the NOVA code is the PyTorch side here
  }
  return d;
}

}  // namespace

int step(const Args& args) {
  const Options o(args, step_defaults(args));
  if (o.help()) {
    std::cout << o.usage("nova-bench step")
              << "\nSeconds per training step (occupancy skipping off: the dense step), device memory, peak\n"
                 "RSS and commands enqueued per step (kernels, CLBlast calls, host calls, memory commands; the\n"
                 "CSV splits them), per preset and phase, then a per-op profile.\n\n"
                 "--scene: the scene folder to step on (required unless --run)\n"
                 "--presets: comma list of presets (quick, reference)\n"
                 "--objects: numbers of object NeRFs K (the scene's first K)\n"
                 "--steps, --warmup: timed steps, and untimed steps before them (kernel builds)\n"
                 "--profile-steps: steps of the per-op profile (0: none)\n"
                 "--factor: image downscale factor of the scene\n"
                 "--out: also write the table as CSV here\n"
                 "--device: OpenCL device, as nova's --device\n"
              << "--run RUN: continue a trained run instead (its config, weights, grids and phase; --scene\n"
                 "  defaults to the run's scene; --presets, --objects and --factor do not apply). With --anchor:\n"
                 "  RUN[,RUN], at most one run per phase, trained on the anchor's scene: nova's steps of that\n"
                 "  phase continue the run (the step a long training takes once it skips empty space)\n"
              << "--torch: auto (/usr/bin/python3, when it has torch), off, or an interpreter's path: each row's\n"
                 "  MLPs alone (the preset's trunk at the step's rows of every NeRF) in PyTorch, alternating\n"
              << "--anchor DIR: the NOVA code anchor (nova_ref: run.sh, data/Balloon1): --rounds times nova's\n"
                 "  pretraining and joint steps, then the NOVA code's (--warmup + --steps of each phase, the\n"
                 "  first --warmup left out), and the ratios NOVA code / nova. Defaults then: --scene\n"
                 "  DIR/data/Balloon1 --factor 2 --presets reference --objects 1 --warmup 1 --steps 3 --torch off;\n"
                 "  NOVA_PRE_STEPS, NOVA_JOINT_STEPS, NOVA_SUMMARY_SKIP, NOVA_NV_START, NOVA_THREADS and\n"
                 "  NOVA_TIMEOUT in the environment override what the NOVA code is given\n"
                 "--anchor-python: the NOVA code's interpreter (auto: $PYTHON, else /usr/bin/python3)\n";
    return 0;
  }
  const long steps = o.integer("steps"), warmup = o.integer("warmup"), profile_steps = o.integer("profile-steps");
  if (steps < 1 || warmup < 0 || profile_steps < 0) throw Error("--steps must be >= 1, --warmup and --profile-steps >= 0");
  if (!o.str("run").empty() && o.str("anchor").empty()) {
    if (o.strings("run").size() != 1) throw Error("--run: one run (two, one per phase, go with --anchor)");
    return step_of_run(o, steps, warmup, profile_steps);
  }
  const ScratchDir scratch("step");
  AnchorRun anchor;
  if (!o.str("anchor").empty()) {  // before any step: a wrong anchor is found at once
    if (o.integer("rounds") < 1) throw Error("--rounds must be >= 1");
    anchor.dir = fs::absolute(o.str("anchor"));
    check_anchor_folder(anchor.dir);
    anchor.python = anchor_python(o.str("anchor-python"));
    check_anchor_python(anchor.python, scratch.path());
  }
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
  if (!o.str("anchor").empty()) {
    if (presets.size() != 1 || objects.size() != 1)
      throw Error("--anchor compares one preset and one object count (the NOVA code's: --presets reference --objects 1)");
    std::vector<TrainedRun> runs;
    if (o.strings("run").size() > 2) throw Error("--run: at most two runs with --anchor, one per phase");
    if (!o.str("run").empty())
      for (const std::string& dir : o.strings("run")) {
        runs.push_back(trained_run(dir, ""));
        const TrainedRun& r = runs.back();
        const Camera& a = scene.frames[0].camera;
        const Camera& b = r.scene.frames[0].camera;
        if (r.files.config.preset != preset_list[0] || r.scene.num_objects != objects[0] || a.width != b.width ||
            a.height != b.height)
          throw Error("--run " + dir + ": trained with preset " + r.files.config.preset + " on " +
                      std::to_string(b.width) + "x" + std::to_string(b.height) + " with " +
                      std::to_string(r.scene.num_objects) + " objects; the NOVA code steps on " +
                      std::to_string(a.width) + "x" + std::to_string(a.height) + " with " +
                      std::to_string(objects[0]) + " (preset " + preset_list[0] + ")");
        if (runs.size() == 2 && joint_checkpoint(runs[0].files) == joint_checkpoint(runs[1].files))
          throw Error("--run: both runs are in the " + std::string(joint_checkpoint(r.files) ? "joint" : "pretraining") +
                      " phase; give at most one run per phase");
      }
    return beside_anchor(o, scene, presets[0], preset_list[0], objects[0], warmup, steps, profile_steps, anchor, scratch,
                         runs);
  }

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
        const Scene s = with_objects(scene, K);
        rows.push_back(time_row(rt, s, presets[pi], preset_list[pi], joint, K, warmup, steps, scratch / "run", python,
                                told_torch));
        if (profile_steps > 0)
          profiles << profile_of(prt, s, presets[pi], preset_list[pi], joint, K, warmup, profile_steps, scratch / "profile");
        print_row(rows.back());
      }
  write_csv(rows, o.str("out"), profiles.str());
  return 0;
}

}  // namespace nova::bench

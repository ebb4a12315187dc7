// `nova train --scene DIR --out RUN [--config FILE] [--resume] [--OPTION VALUE ...]`: trains a
// NOVA scene headless. Options come from the preset, then the config file, then the command
// line (later wins); every option of the table in train_config.hpp is a flag here.
#include <cstdio>
#include <functional>
#include <filesystem>
#include <iostream>

#include "cli/mpi_job.hpp"
#include "cli/options.hpp"
#include "cli/run_setup.hpp"
#include "nova/ops/linalg/gemm.hpp"
#include "nova/data/scene_io.hpp"
#include "nova/train/progress_line.hpp"
#include "nova/train/run_folder.hpp"
#include "nova/runtime/runtime.hpp"
#include "nova/train/trainer.hpp"
#include "runtime/read_file.hpp"

namespace nova::cli {
namespace {

void print_progress(const TrainProgress& p) { std::cerr << progress_line(p) << "\n"; }

}  // namespace

// The command, on one process or as one rank of an MPI job (`mpi`: null for one process).
int train_rank(const Args& args, MpiJob* mpi) {
  const bool lead = !mpi || mpi->rank() == 0;  // rank 0 prints and writes the run folder
  po::options_description desc("nova train options");
  add_common_options(desc);
  desc.add_options()("scene", po::value<std::string>(), "scene folder (nova synth, NOVA/DynamicNeRF, LLFF, Blender); on --resume the run's own by default")(
      "out", po::value<std::string>()->required(), "run folder (config.ini, metrics.jsonl, checkpoint.bin)")(
      "config", po::value<std::string>(), "config file of key = value lines (a run's config.ini works)")(
      "resume", po::bool_switch(), "continue the run in --out from its checkpoint")(
      "profile", po::bool_switch(), "time every op and print the table at the end");
  po::options_description table("training options (default: the quick preset; reference values in [])");
  const TrainConfig quick = preset_config("quick"), reference = preset_config("reference");
  for (const ConfigOption& o : config_options()) {
    std::string help = o.help + " (" + o.get(quick) + ")";
    if (o.get(reference) != o.get(quick)) help += " [" + o.get(reference) + "]";
    table.add_options()(o.key.c_str(), po::value<std::string>(), help.c_str());
  }
  desc.add(table);
  po::variables_map vm;
  if (!parse(args, desc, vm, "usage: nova train --scene DIR --out RUN [--config FILE] [--OPTION VALUE ...]\n"
             "       nova train --out RUN --resume [--scene DIR] [--config FILE] [--OPTION VALUE ...]"))
    return 0;
  const std::string out = vm["out"].as<std::string>();
  check_output_location(out, "--out");
  const RunFolder run(out);
  const bool resume = vm["resume"].as<bool>();

  namespace fs = std::filesystem;
  if (resume && !fs::exists(run.checkpoint_path()))
    throw Error("--resume: run folder '" + out + "' has no " + kCheckpointFile);

  // Preset, then the config file (on --resume: the run's own), then the command line.
  std::string config_path = vm.count("config") ? vm["config"].as<std::string>() : "";
  const bool own_config = resume && config_path.empty();
  if (own_config) config_path = run.config_path();
  TrainConfig config = preset_config(vm.count("preset") ? vm["preset"].as<std::string>() : "quick");
  if (!config_path.empty()) {
    const std::optional<std::string> text = read_file(config_path);
    if (!text) throw Error("config file '" + config_path + "' cannot be read");
    std::vector<std::pair<std::string, std::string>> others;  // e.g. the scene of a config.ini
    config = parse_config_text(*text, config_path, &others,
                               own_config ? ConfigFile::RunFile : ConfigFile::Partial);
    for (auto& [k, v] : others)
      if (k != "scene") throw Error(config_path + ": unknown option '" + k + "'");
  }
  for (const ConfigOption& o : config_options())
    if (o.key != "preset" && vm.count(o.key)) set_config_value(config, o.key, vm[o.key].as<std::string>());
  validate(config);

  if (!resume && fs::exists(out) && !fs::is_empty(out))
    throw Error("run folder '" + out + "' already exists and is not empty: pass --resume to continue it, or choose another --out");
  if (mpi) {
    mpi->limit_waits(training_wait_limit());
    mpi->barrier();  // every rank has checked the folder before rank 0 fills it
  }

  std::string scene_dir = vm.count("scene") ? vm["scene"].as<std::string>() : "";
  if (scene_dir.empty() && resume) scene_dir = named_scene(run.scene(), run.config_path());
  if (scene_dir.empty()) throw Error("--scene is required (a scene folder to train on)");
  Scene scene = load_training_scene(scene_dir, config);
  if (lead) {
    for (const std::string& note : scene.notes)
      if (note.rfind("warning: ", 0) == 0) std::cerr << "nova train: " << note << "\n";
    // A hash grid starts with near-zero features, so every sample's density is one constant;
    // negative and without noise, ReLU passes no gradient (docs/known-issues.md).
    if (config.noise_std == 0.0f && config.field.encoding == Encoding::HashGrid)
      std::cerr << "nova train: warning: --noise-std 0 with the hash-grid encoding can start with zero density "
                   "everywhere and learn nothing (training PSNR flat from the first step); keep some noise\n";
  }
  const DeviceInfo device = mpi ? rank_device(vm["device"].as<std::string>()) : select_device(vm["device"].as<std::string>());
  const bool profile = vm["profile"].as<bool>();
  Runtime rt(device, profile);
  // One write of the whole line: the ranks share mpirun's stderr, where separate writes of
  // its parts interleave with another rank's.
  if (mpi)
    std::cerr << ("nova train: rank " + std::to_string(mpi->rank()) + " of " + std::to_string(mpi->size()) + " on " +
                  device.id() + " " + device.name + "\n");
  if (lead) std::cerr << "nova train: " << scene.name << ", " << scene.frames.size() << " frames at "
            << scene.frames[0].rgb.width << "x" << scene.frames[0].rgb.height << ", 1 + " << scene.num_objects
            << " NeRFs, preset " << config.preset << ", " << config.pretrain_steps << " + " << config.steps
            << " steps on " << device.name << "\n";
  // Which GEMMs run matters for speed (and, through rounding, for the exact numbers).
  const GemmProvider gemms = gemm_provider(rt);
  if (lead) {
    std::cerr << "GEMMs: " << gemm_provider_name(gemms);
    if (gemms == GemmProvider::Tuned)
      std::cerr << " (the tuning cache's winners, else "
                << (host_gemm_available(rt) ? "the host BLAS " + host_blas_library() : std::string("CLBlast")) << ")";
    std::cerr << "\n";
  }
  const bool created = !fs::exists(out);
  try {
    Trainer trainer(rt, scene, config, out, mpi ? &mpi->reducer() : nullptr);
    trainer.set_profile(profile);  // before resume(), which builds the step's executor
    if (resume) {
      trainer.resume();
      if (lead) std::cerr << "resumed at step " << trainer.step() << "\n";
    }
    trainer.run(lead ? print_progress : std::function<void(const TrainProgress&)>());
    if (profile && lead) std::cerr << trainer.profile_table();
  } catch (...) {
    // A run that failed before its first checkpoint leaves nothing behind.
    if (lead && created && !fs::exists(run.checkpoint_path())) fs::remove_all(out);
    throw;
  }
  if (!lead) return 0;
  std::cout << "trained " << out << " (" << kCheckpointFile << ", " << kMetricsFile << ", " << kConfigFile << ")\n";
  return 0;
}

int train(const Args& args) { return run_as_ranks("train", args, train_rank); }

}  // namespace nova::cli

#pragma once
// The NOVA code anchor: the original NOVA training code (PyTorch) with its own runner, a folder
// outside the repository (run.sh, data/Balloon1). nova-bench step runs it as a child process
// between its own steps, so that one run alternates the two and the machine's noise hits both.
// Of its log nova reads the per-step lines ("BENCH phase=pretrain|joint i=.. wall=.. nv=0|1 ...")
// and the closing "BENCH_END key=value ..." line.
#include <filesystem>
#include <istream>
#include <map>
#include <string>
#include <vector>

namespace nova::bench {

// One run of the NOVA code: the wall seconds of each phase's steps from step `skip` on, in
// step order, and the BENCH_END fields (none where the run did not finish).
struct AnchorSteps {
  std::vector<double> pretrain, joint;
  int joint_novel_view = 0;                   // of the timed joint steps, those with novel-view augmentation
  int logged_pretrain = 0, logged_joint = 0;  // every step logged, the skipped ones included
  std::map<std::string, std::string> end;
};

AnchorSteps parse_anchor_log(std::istream& log, int skip);

// An Error naming the folder (exit 2) where it lacks run.sh or data/Balloon1.
void check_anchor_folder(const std::filesystem::path& dir);

// "auto": $PYTHON where set, else /usr/bin/python3.
std::string anchor_python(const std::string& option);

// An Error naming the interpreter and what it lacks (exit 2) where it cannot import the
// modules the NOVA code imports. `scratch` holds its output.
void check_anchor_python(const std::string& python, const std::filesystem::path& scratch);

// What run.sh is given. A variable already set in nova-bench's environment (NOVA_PRE_STEPS,
// NOVA_JOINT_STEPS, NOVA_SUMMARY_SKIP, NOVA_NV_START, NOVA_THREADS, NOVA_TIMEOUT) wins over
// the value here; resolve() applies that.
struct AnchorRun {
  std::filesystem::path dir;  // the anchor folder
  std::filesystem::path out;  // run.sh's OUTDIR: nova_ref.log, and run.out (run.sh's own output)
  std::string python;
  int pre_steps = 4, joint_steps = 4, skip = 1;
  // -1: the NOVA code augments joint steps 0, 3, 6, ..., the steps nova's reference preset
  // augments (augment-every 3 from joint step 0); its runner's own default leaves out step 0.
  int nv_start = -1;
  int threads = 0;  // 0: this machine's hardware threads (Debian's torch starts with one)
  int timeout_s = 0;  // 0: 120 s plus 60 s a step
  bool cpu = true;    // NOVA_DEVICE_CPU=1: torch on the CPU, GPUs hidden

  AnchorRun resolve() const;
  // "pretraining 4 + joint 4 steps, the first 1 of each left out, 2 threads, ..."
  std::string describe() const;
};

// Runs `bash DIR/run.sh OUT` (resolved) and parses its log. An Error (exit 1) naming the
// run's exit status, a time-out, or a log without timed steps, with the run's last lines.
AnchorSteps run_anchor(const AnchorRun& run);

}  // namespace nova::bench

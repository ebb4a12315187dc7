// The NOVA code anchor as a child process (bench/anchor_run.hpp).
#include "anchor_run.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <fstream>
#include <sstream>
#include <thread>
#include <utility>

#include "nova/runtime/error.hpp"

namespace nova::bench {
namespace {

namespace fs = std::filesystem;

std::map<std::string, std::string> fields(const std::string& line) {
  std::map<std::string, std::string> kv;
  std::istringstream words(line);
  std::string w;
  words >> w;  // BENCH or BENCH_END
  while (words >> w)
    if (const size_t eq = w.find('='); eq != std::string::npos) kv[w.substr(0, eq)] = w.substr(eq + 1);
  return kv;
}

struct ChildResult {
  int status = -1;  // exit status, 128 + signal where a signal ended it
  bool killed = false;
};

// Runs argv with its stdout and stderr in `output` and `env` added to nova-bench's own
// ("" unsets a name). The child leads a process group of its own, so that one that runs past
// `limit_s` is killed with all it started (run.sh's timeout and python).
ChildResult run_to_file(const std::vector<std::string>& argv, const std::vector<std::pair<std::string, std::string>>& env,
                        const fs::path& output, double limit_s) {
  const pid_t pid = fork();
  if (pid < 0) throw Error("cannot start " + argv[0] + ": " + std::strerror(errno), kExitInternal);
  if (pid == 0) {
    setpgid(0, 0);
    const int out = open(output.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int null = open("/dev/null", O_RDONLY);
    if (out < 0 || null < 0) _exit(126);
    dup2(null, STDIN_FILENO);
    dup2(out, STDOUT_FILENO);
    dup2(out, STDERR_FILENO);
    for (const auto& [k, v] : env) v.empty() ? unsetenv(k.c_str()) : setenv(k.c_str(), v.c_str(), 1);
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    execvp(args[0], args.data());
    const std::string msg = "cannot execute " + argv[0] + ": " + std::strerror(errno) + "\n";
    (void)!write(STDOUT_FILENO, msg.data(), msg.size());
    _exit(127);
  }
  const auto start = std::chrono::steady_clock::now();
  ChildResult r;
  int st = 0;
  for (;;) {
    const pid_t done = waitpid(pid, &st, WNOHANG);
    if (done == pid) break;
    if (done < 0 && errno != EINTR) throw Error("lost the child process " + argv[0], kExitInternal);
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > limit_s) {
      kill(-pid, SIGKILL);
      kill(pid, SIGKILL);
      waitpid(pid, &st, 0);
      r.killed = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : WIFSIGNALED(st) ? 128 + WTERMSIG(st) : -1;
  return r;
}

std::string last_lines(const fs::path& file, size_t n) {
  std::ifstream in(file);
  std::deque<std::string> lines;
  for (std::string line; std::getline(in, line);) {
    if (line.empty()) continue;
    lines.push_back(line);
    if (lines.size() > n) lines.pop_front();
  }
  std::string s;
  for (const std::string& l : lines) s += "\n  " + l;
  return s;
}

int env_or(const char* name, int value) {
  const char* v = std::getenv(name);
  if (!v || !*v) return value;
  try {
    return std::stoi(v);
  } catch (const std::exception&) {
    throw Error(std::string(name) + " must be an integer, got '" + v + "'");
  }
}

}  // namespace

AnchorSteps parse_anchor_log(std::istream& log, int skip) {
  AnchorSteps s;
  for (std::string line; std::getline(log, line);) {
    if (line.rfind("BENCH_END ", 0) == 0) {
      s.end = fields(line);
      continue;
    }
    if (line.rfind("BENCH ", 0) != 0) continue;
    const auto kv = fields(line);
    int i = 0, nv = 0;
    double wall = 0;
    try {  // a line another write broke into is no step
      i = std::stoi(kv.at("i"));
      wall = std::stod(kv.at("wall"));
      nv = std::stoi(kv.at("nv"));
    } catch (const std::exception&) {
      continue;
    }
    const std::string& phase = kv.count("phase") ? kv.at("phase") : std::string();
    if (phase == "pretrain") {
      ++s.logged_pretrain;
      if (i >= skip) s.pretrain.push_back(wall);
    } else if (phase == "joint") {
      ++s.logged_joint;
      if (i >= skip) {
        s.joint.push_back(wall);
        s.joint_novel_view += nv == 1;
      }
    }
  }
  return s;
}

void check_anchor_folder(const fs::path& dir) {
  if (!fs::is_directory(dir)) throw Error("--anchor: '" + dir.string() + "' is no folder (the NOVA code anchor, nova_ref)");
  for (const char* part : {"run.sh", "data/Balloon1"})
    if (!fs::exists(dir / part))
      throw Error("--anchor: '" + dir.string() + "' has no " + part + " (not the NOVA code anchor, nova_ref)");
}

std::string anchor_python(const std::string& option) {
  if (option != "auto") return option;
  const char* p = std::getenv("PYTHON");
  return p && *p ? p : "/usr/bin/python3";
}

void check_anchor_python(const std::string& python, const fs::path& scratch) {
  const fs::path out = scratch / "python-check.txt";
  const ChildResult r = run_to_file({python, "-c", "import torch, numpy, cv2, imageio, PIL"}, {}, out, 120);
  if (r.status == 0) return;
  throw Error("--anchor-python: " + python + " cannot run the NOVA code:" + last_lines(out, 1) +
              "\n  (Debian: apt-get install python3-torch python3-numpy python3-opencv python3-imageio python3-pil;"
              " or name another interpreter with --anchor-python)");
}

AnchorRun AnchorRun::resolve() const {
  AnchorRun r = *this;
  r.pre_steps = env_or("NOVA_PRE_STEPS", pre_steps);
  r.joint_steps = env_or("NOVA_JOINT_STEPS", joint_steps);
  r.skip = env_or("NOVA_SUMMARY_SKIP", skip);
  r.nv_start = env_or("NOVA_NV_START", nv_start);
  r.threads = env_or("NOVA_THREADS", threads > 0 ? threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
  r.timeout_s = env_or("NOVA_TIMEOUT", timeout_s > 0 ? timeout_s : 120 + 60 * (r.pre_steps + r.joint_steps));
  return r;
}

std::string AnchorRun::describe() const {
  std::ostringstream s;
  s << "pretraining " << pre_steps << " + joint " << joint_steps << " steps a round, the first " << skip
    << " of each left out; novel-view joint steps i % 3 == 0, i > " << nv_start << "; "
    << (cpu ? "CPU, " + std::to_string(threads) + " threads" : std::string("CUDA")) << "; time-out " << timeout_s
    << " s; " << python;
  return s.str();
}

AnchorSteps run_anchor(const AnchorRun& run) {
  fs::create_directories(run.out);
  const fs::path output = run.out / "run.out", log = run.out / "nova_ref.log";
  const std::vector<std::pair<std::string, std::string>> env = {
      {"NOVA_PRE_STEPS", std::to_string(run.pre_steps)},  {"NOVA_JOINT_STEPS", std::to_string(run.joint_steps)},
      {"NOVA_SUMMARY_SKIP", std::to_string(run.skip)},    {"NOVA_NV_START", std::to_string(run.nv_start)},
      {"NOVA_THREADS", std::to_string(run.threads)},      {"NOVA_TIMEOUT", std::to_string(run.timeout_s)},
      {"NOVA_DEVICE_CPU", run.cpu ? "1" : ""},            {"PYTHON", run.python}};
  const std::string what = "the NOVA code (bash " + (run.dir / "run.sh").string() + ")";
  // run.sh's own time-out covers the training; the margin is its start and its summary.
  const ChildResult r = run_to_file({"bash", (run.dir / "run.sh").string(), run.out.string()}, env, output,
                                    run.timeout_s + 60.0);
  const std::string tail = "; its last lines:" + last_lines(output, 12);
  if (r.killed) throw Error(what + " did not end within " + std::to_string(run.timeout_s + 60) + " s" + tail, kExitInternal);
  if (r.status == 124)
    throw Error(what + " timed out: NOVA_TIMEOUT=" + std::to_string(run.timeout_s) + " s was too short for " +
                    std::to_string(run.pre_steps) + " + " + std::to_string(run.joint_steps) + " steps" + tail,
                kExitInternal);
  if (r.status != 0) throw Error(what + " failed with exit status " + std::to_string(r.status) + tail, kExitInternal);
  std::ifstream in(log);
  if (!in) throw Error(what + " wrote no log '" + log.string() + "'" + tail, kExitInternal);
  AnchorSteps s = parse_anchor_log(in, run.skip);
  if (s.pretrain.empty() || s.joint.empty())
    throw Error(what + ": its log '" + log.string() + "' has " + std::to_string(s.pretrain.size()) + " pretraining and " +
                    std::to_string(s.joint.size()) + " joint steps from step " + std::to_string(run.skip) +
                    " on (logged " + std::to_string(s.logged_pretrain) + " and " + std::to_string(s.logged_joint) +
                    "); it needs both" + tail,
                kExitInternal);
  return s;
}

}  // namespace nova::bench

#include "torch_peer.hpp"

#include <algorithm>
#include <csignal>
#include <thread>
#include <filesystem>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

#include "nova/runtime/error.hpp"
#include "torch_mlp_script.hpp"  // generated: kTorchMlpScript, the text of bench/torch_mlp.py

namespace nova::bench {

std::string torch_python(const std::string& option) {
  if (option == "off") return {};
  if (option == "auto") return std::filesystem::exists("/usr/bin/python3") ? "/usr/bin/python3" : "";
  return option;
}

std::unique_ptr<TorchPeer> TorchPeer::start(const std::string& python, const TorchMlpShape& s,
                                            std::string& why) {
  // A child that dies makes a later write fail (EPIPE, "has gone") instead of killing the bench.
  std::signal(SIGPIPE, SIG_IGN);
  int down[2], up[2];
  if (pipe(down) != 0) throw Error("nova-bench: cannot create a pipe for PyTorch");
  if (pipe(up) != 0) {
    close(down[0]);
    close(down[1]);
    throw Error("nova-bench: cannot create a pipe for PyTorch");
  }
  const int threads = s.threads > 0 ? s.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::vector<std::string> args = {python, "-c", kTorchMlpScript, std::to_string(s.batch),
                                   "--threads", std::to_string(threads), "--inputs", std::to_string(s.inputs),
                                   "--width", std::to_string(s.width), "--depth", std::to_string(s.depth),
                                   "--skip", std::to_string(s.skip), "--device", s.device};
  if (s.forward_only) args.push_back("--forward-only");
  const pid_t pid = fork();
  if (pid < 0) throw Error("nova-bench: cannot start " + python);
  if (pid == 0) {
    dup2(down[0], STDIN_FILENO);
    dup2(up[1], STDOUT_FILENO);
    for (int fd : {down[0], down[1], up[0], up[1]}) close(fd);
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv(python.c_str(), argv.data());
    const char msg[] = "unavailable: cannot execute the interpreter\n";
    (void)!write(STDOUT_FILENO, msg, sizeof msg - 1);
    _exit(127);
  }
  close(down[0]);
  close(up[1]);
  std::unique_ptr<TorchPeer> peer(new TorchPeer(pid, down[1], up[0]));
  const std::string hello = peer->read_line();
  if (hello.rfind("ready ", 0) != 0) {
    why = python + ": " + (hello.empty() ? std::string("no answer") : hello);
    return nullptr;
  }
  peer->version_ = hello.substr(6);
  return peer;
}

std::string TorchPeer::read_line() {
  char buf[256];
  for (;;) {
    const size_t nl = buffered_.find('\n');
    if (nl != std::string::npos) {
      std::string line = buffered_.substr(0, nl);
      buffered_.erase(0, nl + 1);
      return line;
    }
    const ssize_t n = read(from_, buf, sizeof buf);
    if (n <= 0) {
      std::string rest;
      rest.swap(buffered_);
      return rest;
    }
    buffered_.append(buf, static_cast<size_t>(n));
  }
}

double TorchPeer::step() {
  static const char request[] = "step\n";
  if (write(to_, request, sizeof request - 1) != static_cast<ssize_t>(sizeof request - 1))
    throw Error("nova-bench: the PyTorch process has gone");
  const std::string answer = read_line();
  try {
    return std::stod(answer);
  } catch (const std::exception&) {
    throw Error("nova-bench: the PyTorch process answered '" + answer + "' instead of seconds");
  }
}

TorchPeer::~TorchPeer() {
  close(to_);  // end of input: the script exits
  close(from_);
  int status = 0;
  if (waitpid(pid_, &status, 0) < 0) kill(pid_, SIGKILL);
}

}  // namespace nova::bench

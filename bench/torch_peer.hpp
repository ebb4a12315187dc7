#pragma once
// A PyTorch training step of the reference MLP in a child process (bench/torch_mlp.py, embedded
// into nova-bench at build time), driven one step at a time so that a benchmark can alternate
// it with its own steps: the two never run at once and see the same machine state.
#include <memory>
#include <string>
#include <sys/types.h>

namespace nova::bench {

struct TorchMlpShape {
  size_t batch = 65536;
  int inputs = 63, width = 256, depth = 8, skip = 4;
  int threads = 0;  // 0: this machine's hardware threads
  std::string device = "cpu";  // PyTorch's device: cpu, or cuda[:N] (each step then synchronises)
  bool forward_only = false;
};

class TorchPeer {
 public:
  // Starts `python` on the embedded script. Returns nullptr, with the reason in `why`, where
  // the interpreter cannot be run or has no torch.
  static std::unique_ptr<TorchPeer> start(const std::string& python, const TorchMlpShape& shape,
                                          std::string& why);
  ~TorchPeer();
  TorchPeer(const TorchPeer&) = delete;
  TorchPeer& operator=(const TorchPeer&) = delete;

  // Seconds of one step, as the child measured it.
  double step();
  // "torch 1.13.1 threads 2", from the child's greeting.
  const std::string& version() const { return version_; }

 private:
  TorchPeer(pid_t pid, int to_child, int from_child) : pid_(pid), to_(to_child), from_(from_child) {}
  std::string read_line();

  pid_t pid_;
  int to_, from_;
  std::string buffered_, version_;
};

// The interpreter `--torch` names: "auto" is /usr/bin/python3 when it exists, "off" none.
std::string torch_python(const std::string& option);

}  // namespace nova::bench

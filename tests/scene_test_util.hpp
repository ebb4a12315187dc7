#pragma once
#include <sys/wait.h>

#include <cstdlib>
// Helpers for the data-layer suites: unique temporary folders under /tmp and a cached tiny
// synthetic scene that tests copy and then damage.
#include <boost/test/unit_test.hpp>
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>
#include <unistd.h>

#include "nova/runtime/error.hpp"
#include "nova/data/synth.hpp"
#include "nova/model/scene.hpp"

namespace nova::test {

namespace fs = std::filesystem;

// A fresh folder, removed with everything in it when the object goes away.
class TempDir {
 public:
  explicit TempDir(const std::string& tag) {
    std::random_device rd;
    path_ = fs::temp_directory_path() /
            ("nova-" + tag + "-" + std::to_string(::getpid()) + "-" + std::to_string(rd()));
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const fs::path& path() const { return path_; }
  fs::path operator/(const std::string& s) const { return path_ / s; }

 private:
  fs::path path_;
};

// A (2 radius + 1)^2 box blur of `d`, the box cut at the image's edges: a disparity blurred
// over the objects' silhouettes, as a depth network's.
inline void box_blur(ImageF& d, int radius) {
  const int W = d.width, H = d.height;
  std::vector<float> out(d.data.size());
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      double sum = 0;
      int n = 0;
      for (int v = std::max(0, y - radius); v <= std::min(H - 1, y + radius); ++v)
        for (int u = std::max(0, x - radius); u <= std::min(W - 1, x + radius); ++u, ++n)
          sum += d.data[static_cast<size_t>(v) * W + u];
      out[static_cast<size_t>(y) * W + x] = static_cast<float>(sum / n);
    }
  d.data = std::move(out);
}

// The tiny synthetic scene (seed 7), generated once per process; returns its folder.
inline const fs::path& cached_tiny_scene() {
  static TempDir dir("tiny-cache");
  static const fs::path scene = [] {
    const fs::path p = dir / "scene";
    write_synthetic_scene(p.string(), "tiny", 7);
    return p;
  }();
  return scene;
}

// A private copy of the tiny scene in `into`/scene, to modify.
inline fs::path copy_tiny_scene(const TempDir& into) {
  const fs::path dst = into / "scene";
  fs::copy(cached_tiny_scene(), dst, fs::copy_options::recursive);
  return dst;
}

inline std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

inline void write_all(const fs::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out << bytes;
}

// A program of this build run as a user runs it: `program` is a file name in the build folder
// (nova, nova-bench), `args` its arguments; stdout and stderr go to files in `dir`.
struct CommandResult {
  int code = -1;  // exit code; -1 when it did not exit (a signal)
  std::string out, err;
};
inline CommandResult run_built(const std::string& program, const std::string& args, const TempDir& dir,
                               const std::string& env = "") {
  const std::string out = (dir / "stdout.txt").string(), err = (dir / "stderr.txt").string();
  const std::string cmd = env + " " + std::string(NOVA_BINARY_DIR) + "/" + program + " " + args + " >" + out + " 2>" + err;
  const int status = std::system(cmd.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, read_all(out), read_all(err)};
}
inline bool built(const std::string& program) { return fs::exists(fs::path(NOVA_BINARY_DIR) / program); }

// Raw .npy bytes with any descr/shape text, for malformed-input tests.
inline std::string npy_bytes(const std::string& descr, const std::string& shape,
                             const std::string& payload, bool fortran = false) {
  std::string dict = "{'descr': '" + descr + "', 'fortran_order': " +
                     (fortran ? "True" : "False") + ", 'shape': " + shape + ", }";
  while ((10 + dict.size() + 1) % 64) dict += ' ';
  dict += '\n';
  std::string out("\x93NUMPY\x01\x00", 8);
  out += char(dict.size() & 0xff);
  out += char(dict.size() >> 8);
  return out + dict + payload;
}

// Runs `f`, expecting a nova::Error with exit code 2 whose message contains every string
// in `parts`.
template <class F>
void expect_error(F&& f, const std::vector<std::string>& parts) {
  try {
    f();
  } catch (const nova::Error& e) {
    const std::string msg = e.what();
    BOOST_TEST_MESSAGE("error: " << msg);
    BOOST_TEST(e.exit_code() == 2);
    for (const auto& p : parts) BOOST_TEST(msg.find(p) != std::string::npos, "'" << p << "' in: " << msg);
    return;
  }
  BOOST_ERROR("expected a nova::Error");
}

}  // namespace nova::test

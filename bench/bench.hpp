#pragma once
// nova-bench: one subcommand per benchmark, each printing a table and CSV (and PNG plots
// where a picture says more). Speeds are compared as ratios inside one run: shared machines
// are noisy.
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace nova::bench {

using Args = std::vector<std::string>;

int mlp(const Args& args);
int render(const Args& args);
int ops(const Args& args);  // the op table (tests/op_table.hpp, library nova_op_table)
#ifdef NOVA_BENCH_IO
int tradeoff(const Args& args);  // needs nova_io (scenes, metrics, the plot)
int view(const Args& args);      // needs nova_io (the run's scene)
int accuracy(const Args& args);  // needs nova_io (scenes, metrics, pictures)
int step(const Args& args);      // needs nova_io (the scene)
int devices(const Args& args);   // needs nova_io (the scene, its evaluation, the plot)
int masks(const Args& args);     // needs nova_io (nova masks against known masks)
int motion(const Args& args);    // needs nova_io (the rigid start against the family's exact poses)
#endif

struct Benchmark {
  const char* name;
  const char* summary;
  int (*run)(const Args&);
};
const std::vector<Benchmark>& benchmarks();

// The middle value (the upper one of an even count; 0 for none).
double median(std::vector<double> v);

// Median of `repeats` timings of `fn` (seconds), after one untimed warm-up call.
double time_median(int repeats, const std::function<void()>& fn);

// A private folder under the system's temporary directory (named for `what` and the process),
// removed with everything in it when the object goes.
class ScratchDir {
 public:
  explicit ScratchDir(const std::string& what);
  ~ScratchDir();
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }

 private:
  std::filesystem::path path_;
};

}  // namespace nova::bench

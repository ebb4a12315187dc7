// MpiJob (mpi_job.hpp): MPI_Init when launched by mpirun, an all-gather reducer summing in
// rank order, MPI_Abort for a rank that fails, and a watchdog for collective calls that never
// return.
#include "cli/mpi_job.hpp"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdlib>
#include <iostream>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "nova/runtime/error.hpp"
#include "runtime/parse_number.hpp"

#ifdef NOVA_WITH_MPI
#include <mpi.h>
#endif

namespace nova::cli {
namespace {

int env_int(const char* name, int fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::atoi(v) : fallback;
}

// The launcher's world size, from the environment (0: not launched by one). Slurm's PMIx
// plugin gives a rank but no size; the step's task count is the size then.
int launched_size() {
  for (const char* k : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"})
    if (const int n = env_int(k, 0); n > 0) return n;
  if (std::getenv("PMIX_RANK") || std::getenv("PMI_RANK")) return std::max(1, env_int("SLURM_STEP_NUM_TASKS", 1));
  return 0;
}

#ifdef NOVA_WITH_MPI
void check(int rc, const char* call) {
  if (rc != MPI_SUCCESS) {
    char text[MPI_MAX_ERROR_STRING];
    int n = 0;
    MPI_Error_string(rc, text, &n);
    throw Error(std::string(call) + ": " + std::string(text, static_cast<size_t>(n)), kExitInternal);
  }
}

// Ends the process when a collective call has waited longer than the limit. A rank that
// stops answering (alive, so mpirun sees nothing wrong) would otherwise hold every other rank
// in its next collective call for ever; a rank that exits without MPI_Finalize makes mpirun
// end the whole job. The thread only reads a clock: it calls no MPI function.
class Watchdog {
 public:
  explicit Watchdog(int rank) : rank_(rank) {}
  ~Watchdog() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
  }
  void limit(double seconds) {
    limit_s_ = seconds;
    if (seconds > 0 && !thread_.joinable()) thread_ = std::thread([this] { watch(); });
  }
  // Marks the collective call `what` as waiting for the duration of a scope.
  class Wait {
   public:
    Wait(Watchdog& w, const char* what) : w_(w) {
      w_.what_ = what;
      w_.since_ms_ = now_ms();
    }
    ~Wait() { w_.since_ms_ = 0; }

   private:
    Watchdog& w_;
  };

 private:
  static long long now_ms() {
    return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now().time_since_epoch()).count();
  }
  void watch() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (!wake_.wait_for(lock, std::chrono::milliseconds(200), [this] { return stop_; })) {
      const long long since = since_ms_;
      if (since == 0 || now_ms() - since <= static_cast<long long>(limit_s_ * 1000.0)) continue;
      std::cerr << "nova: rank " << rank_ << ": error: waited " << limit_s_ << " s in " << what_.load()
                << " for the other ranks (NOVA_MPI_TIMEOUT); a rank has stopped answering, ending the job"
                << std::endl;
      std::_Exit(kExitInternal);
    }
  }

  int rank_;
  double limit_s_ = 0;
  std::atomic<long long> since_ms_{0};
  std::atomic<const char*> what_{""};
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  std::thread thread_;
};

// Every rank's values gathered, then summed in rank order: the same bits on every rank.
class MpiReducer final : public GradientReducer {
 public:
  MpiReducer(int rank, int size, Watchdog& watchdog) : rank_(rank), size_(size), watchdog_(watchdog) {}
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  void sum(std::vector<float>& values) override {
    const Watchdog::Wait wait(watchdog_, "a gradient sum");
    const size_t n = values.size();
    all_.resize(n * static_cast<size_t>(size_));
    check(MPI_Allgather(values.data(), static_cast<int>(n), MPI_FLOAT, all_.data(), static_cast<int>(n), MPI_FLOAT,
                        MPI_COMM_WORLD),
          "MPI_Allgather");
    for (size_t i = 0; i < n; ++i) {
      float t = 0.0f;
      for (int r = 0; r < size_; ++r) t += all_[static_cast<size_t>(r) * n + i];
      values[i] = t;
    }
  }

 private:
  int rank_, size_;
  Watchdog& watchdog_;
  std::vector<float> all_;
};

class Mpi final : public MpiJob {
 public:
  Mpi() {
    check(MPI_Init(nullptr, nullptr), "MPI_Init");
    // Errors come back as codes (thrown as nova errors, then abort()), never a silent hang.
    MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
    // A launcher whose PMI this MPI does not speak leaves every process a world of its own.
    if (const int launched = launched_size(); size_ != launched) {
      MPI_Finalize();
      throw Error("launched as one of " + std::to_string(launched) + " ranks, but MPI sees " + std::to_string(size_) +
                  " (each would train alone into the same folder): start the ranks with mpirun, or with srun "
                  "--mpi=PLUGIN where Slurm and this MPI share a PMI");
    }
    watchdog_ = std::make_unique<Watchdog>(rank_);
    reducer_ = std::make_unique<MpiReducer>(rank_, size_, *watchdog_);
  }
  ~Mpi() override {
    watchdog_.reset();
    MPI_Finalize();
  }
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  GradientReducer& reducer() override { return *reducer_; }
  void barrier() override {
    const Watchdog::Wait wait(*watchdog_, "a barrier");
    check(MPI_Barrier(MPI_COMM_WORLD), "MPI_Barrier");
  }
  void limit_waits(double seconds) override { watchdog_->limit(seconds); }
  [[noreturn]] void abort(int code) override {
    MPI_Abort(MPI_COMM_WORLD, code);
    std::exit(code);
  }

 private:
  int rank_ = 0, size_ = 1;
  std::unique_ptr<Watchdog> watchdog_;
  std::unique_ptr<MpiReducer> reducer_;
};
#endif

}  // namespace

std::unique_ptr<MpiJob> start_mpi_job() {
  const int n = launched_size();
  // srun without a PMI that this MPI speaks starts every task as a lone process: each would
  // train alone and all would write the same run folder.
  if (const int tasks = env_int("SLURM_STEP_NUM_TASKS", 0); n == 0 && tasks > 1)
    throw Error("srun started " + std::to_string(tasks) + " tasks, but no MPI launcher told this nova of the others "
                "(each would train alone into the same folder): start the ranks with mpirun inside the allocation, "
                "or with srun --mpi=PLUGIN where Slurm and this MPI share a PMI");
  if (n == 0) return nullptr;
#ifdef NOVA_WITH_MPI
  return std::make_unique<Mpi>();
#else
  if (n > 1)
    throw Error("started as one of " + std::to_string(n) + " MPI ranks, but this nova was built without MPI "
                "(install libopenmpi-dev and rebuild, NOVA_MPI=ON)");
  return nullptr;
#endif
}

int run_as_ranks(const char* command, const std::vector<std::string>& args,
                 int (*body)(const std::vector<std::string>&, MpiJob*)) {
  std::unique_ptr<MpiJob> mpi = start_mpi_job();
  if (!mpi || mpi->size() == 1) return body(args, nullptr);
  try {
    return body(args, mpi.get());
  } catch (const std::exception& e) {
    // One write of the whole line (other ranks write to the same stderr).
    std::cerr << (std::string("nova ") + command + ": rank " + std::to_string(mpi->rank()) + ": error: " + e.what() + "\n")
              << std::flush;
    const auto* error = dynamic_cast<const Error*>(&e);
    mpi->abort(error ? error->exit_code() : kExitInternal);
  }
  return kExitInternal;  // abort() does not return
}

double training_wait_limit() {
  const char* v = std::getenv("NOVA_MPI_TIMEOUT");
  if (!v || !*v) return 600.0;
  const std::optional<double> s = parse_whole_double(v);
  if (!s || !std::isfinite(*s) || *s < 0)
    throw Error(std::string("NOVA_MPI_TIMEOUT='") + v + "': expected seconds (a number >= 0; 0: no limit)", kExitUsage);
  return *s;
}

DeviceInfo rank_device(const std::string& selector) {
  const char* env = std::getenv("NOVA_DEVICE");
  const std::string chosen = !selector.empty() ? selector : (env ? env : "");
  std::string type = chosen;
  std::transform(type.begin(), type.end(), type.begin(), [](unsigned char c) { return std::tolower(c); });
  if (!chosen.empty() && type != "cpu" && type != "gpu") return select_device(chosen);
  const int local = env_int("OMPI_COMM_WORLD_LOCAL_RANK", env_int("MPI_LOCALRANKID", env_int("SLURM_LOCALID", 0)));
  std::vector<DeviceInfo> gpus, cpus;
  for (const DeviceInfo& d : list_devices()) {
    if (d.type & CL_DEVICE_TYPE_GPU) gpus.push_back(d);
    else if (type != "cpu" || (d.type & CL_DEVICE_TYPE_CPU)) cpus.push_back(d);
  }
  const std::vector<DeviceInfo>& pool = type == "cpu" ? cpus : type == "gpu" ? gpus : gpus.empty() ? cpus : gpus;
  if (pool.empty()) return select_device(chosen);  // the usual error: no device (of that type)
  return pool[static_cast<size_t>(local) % pool.size()];
}

}  // namespace nova::cli

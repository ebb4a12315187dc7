// MpiJob (mpi_job.hpp): MPI_Init when launched by mpirun, an all-gather reducer summing in
// rank order, and MPI_Abort for a rank that fails.
#include "cli/mpi_job.hpp"

#include <cstdlib>
#include <iostream>
#include <vector>

#include "nova/error.hpp"

#ifdef NOVA_WITH_MPI
#include <mpi.h>
#endif

namespace nova::cli {
namespace {

int env_int(const char* name, int fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::atoi(v) : fallback;
}

// The launcher's world size, from the environment (0: not launched by one).
int launched_size() {
  for (const char* k : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_SIZE"})
    if (const int n = env_int(k, 0); n > 0) return n;
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

// Every rank's values gathered, then summed in rank order: the same bits on every rank.
class MpiReducer final : public GradientReducer {
 public:
  MpiReducer(int rank, int size) : rank_(rank), size_(size) {}
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  void sum(std::vector<float>& values) override {
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
    reducer_ = std::make_unique<MpiReducer>(rank_, size_);
  }
  ~Mpi() override { MPI_Finalize(); }
  int rank() const override { return rank_; }
  int size() const override { return size_; }
  GradientReducer& reducer() override { return *reducer_; }
  void barrier() override { check(MPI_Barrier(MPI_COMM_WORLD), "MPI_Barrier"); }
  [[noreturn]] void abort(int code) override {
    MPI_Abort(MPI_COMM_WORLD, code);
    std::exit(code);
  }

 private:
  int rank_ = 0, size_ = 1;
  std::unique_ptr<MpiReducer> reducer_;
};
#endif

}  // namespace

std::unique_ptr<MpiJob> start_mpi_job() {
  const int n = launched_size();
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
  } catch (const Error& e) {
    std::cerr << "nova " << command << ": rank " << mpi->rank() << ": error: " << e.what() << std::endl;
    mpi->abort(e.exit_code());
  } catch (const std::exception& e) {
    std::cerr << "nova " << command << ": rank " << mpi->rank() << ": error: " << e.what() << std::endl;
    mpi->abort(kExitInternal);
  }
  return kExitInternal;  // abort() does not return
}

DeviceInfo rank_device(const std::string& selector) {
  const char* env = std::getenv("NOVA_DEVICE");
  if (!selector.empty() || (env && *env)) return select_device(selector);
  const int local = env_int("OMPI_COMM_WORLD_LOCAL_RANK", env_int("MPI_LOCALRANKID", env_int("SLURM_LOCALID", 0)));
  std::vector<DeviceInfo> gpus, cpus;
  for (const DeviceInfo& d : list_devices()) ((d.type & CL_DEVICE_TYPE_GPU) ? gpus : cpus).push_back(d);
  const std::vector<DeviceInfo>& pool = gpus.empty() ? cpus : gpus;
  if (pool.empty()) return select_device(selector);  // the usual error: no device
  return pool[static_cast<size_t>(local) % pool.size()];
}

}  // namespace nova::cli

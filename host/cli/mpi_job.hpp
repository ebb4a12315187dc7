#pragma once
// `nova train` under mpirun: one rank per process, each on its own device, training one run
// together (distributed.hpp). Built with MPI when CMake finds it (NOVA_MPI=AUTO|ON|OFF); the
// core never links it.
#include <memory>
#include <string>
#include <vector>

#include "nova/graph/distributed.hpp"
#include "nova/runtime/runtime.hpp"

namespace nova::cli {

class MpiJob {
 public:
  virtual ~MpiJob() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  virtual GradientReducer& reducer() = 0;
  virtual void barrier() = 0;
  // From now on, a collective call (gradient sum, barrier) that waits longer than `seconds`
  // for the other ranks ends this rank with an error, and mpirun then ends the job: a rank
  // that hangs (alive but stuck, e.g. in a driver) cannot hold the others forever. 0: no limit.
  virtual void limit_waits(double seconds) = 0;
  // Ends every rank of the job (after this rank has printed its error).
  [[noreturn]] virtual void abort(int code) = 0;
};

// The job when this process was started by mpirun (Open MPI's or a PMI launcher's variables),
// else null. Error (exit 2) when it was, but nova was built without MPI.
std::unique_ptr<MpiJob> start_mpi_job();

// Runs `body` on one process, or, under mpirun with more than one rank, as this rank of the
// job: a rank that fails prints "nova COMMAND: rank R: error: ..." and ends the job (the other
// ranks would wait for it at their next collective call).
int run_as_ranks(const char* command, const std::vector<std::string>& args,
                 int (*body)(const std::vector<std::string>&, MpiJob*));

// The wait limit of a training job: NOVA_MPI_TIMEOUT (seconds, 0: none), else 600. Error
// (exit 2) naming the variable when it is not a number >= 0.
double training_wait_limit();

// The device of this rank: the node-local rank's GPU, else its CPU device, counting the
// node's devices of that type round-robin; `selector` (--device, else NOVA_DEVICE) "cpu" or
// "gpu" deals out the devices of that type alike, any other selector names one device for
// every rank.
DeviceInfo rank_device(const std::string& selector);

}  // namespace nova::cli

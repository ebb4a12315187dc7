#pragma once
// One exception type for everything a user can get wrong (bad input, bad option, no device)
// and for failures of the OpenCL stack. The CLI maps it to a one-line message and exit code.
#include <stdexcept>
#include <string>

namespace nova {

// Exit codes the CLI uses: 2 for anything the user can fix (input, option, device choice),
// 1 for internal or driver failures.
inline constexpr int kExitUsage = 2;
inline constexpr int kExitInternal = 1;

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what, int exit_code = kExitUsage)
      : std::runtime_error(what), exit_code_(exit_code) {}
  int exit_code() const { return exit_code_; }

 private:
  int exit_code_;
};

// Raised for OpenCL API failures: carries the call and the status name.
class ClError : public Error {
 public:
  ClError(const std::string& call, int status);
  int status() const { return status_; }

 private:
  int status_;
};

const char* cl_status_name(int status);

}  // namespace nova

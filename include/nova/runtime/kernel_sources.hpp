#pragma once
// The OpenCL C sources of kernels/*.cl, embedded at build time (cmake/embed_kernels.cmake).
#include <string_view>
#include <vector>

namespace nova {

struct KernelSource {
  std::string_view family;  // file name without .cl, e.g. "bias_act"
  std::string_view source;
};

const std::vector<KernelSource>& kernel_sources();

// The family compiled ahead of every other (kernels/common.cl): shared helpers, no kernels.
inline constexpr std::string_view kKernelPrelude = "common";

}  // namespace nova

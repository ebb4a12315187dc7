// `nova devices`: every OpenCL platform and device, and which one nova would choose.
#include <iomanip>
#include <iostream>

#include "cli/options.hpp"
#include "nova/ops/linalg/gemm.hpp"
#include "nova/tuning/tuning.hpp"
#include "nova/runtime/runtime.hpp"

namespace nova::cli {

int devices(const Args& args) {
  po::options_description desc("nova devices options");
  add_common_options(desc);
  po::variables_map vm;
  if (!parse(args, desc, vm, "usage: nova devices [--device SEL]")) return 0;

  const auto all = list_devices();
  if (all.empty()) select_device();  // throws the "no platform, install ..." error
  const DeviceInfo chosen = select_device(vm["device"].as<std::string>());
  std::cout << std::left << std::setw(6) << "id" << std::setw(6) << "type" << std::setw(5)
            << "CUs" << std::setw(11) << "memory" << std::setw(12) << "max alloc"
            << std::setw(22) << "OpenCL" << "name (platform)\n";
  for (const auto& d : all) {
    const bool is_chosen = d.platform == chosen.platform && d.device == chosen.device;
    std::cout << std::left << std::setw(6) << d.id() << std::setw(6) << d.type_name()
              << std::setw(5) << d.compute_units << std::setw(11)
              << (std::to_string(d.global_mem_bytes >> 20) + " MiB") << std::setw(12)
              << (std::to_string(d.max_alloc_bytes >> 20) + " MiB") << std::setw(22)
              << d.opencl_version.substr(0, 21) << d.name << " (" << d.platform_name << ")"
              << (is_chosen ? "  <- chosen" : "") << "\n";
  }
  std::cout << "GEMM tuning for the chosen device: " << device_tuning(chosen).name << "\n";
  if (host_gemm_available(chosen))
    std::cout << "host BLAS for the chosen device: " << host_blas_library()
              << " (GEMMs without a tuned winner run on it; NOVA_GEMM, NOVA_HOST_BLAS change that)\n";
  return 0;
}

}  // namespace nova::cli

#pragma once
// Option parsing shared by the subcommands.
#include <boost/program_options.hpp>
#include <iostream>

#include "cli/commands.hpp"

namespace nova::cli {

namespace po = boost::program_options;

// Adds --help and --device to `desc`.
inline void add_common_options(po::options_description& desc) {
  desc.add_options()("help,h", "show this help")(
      "device", po::value<std::string>()->default_value(""),
      "OpenCL device: P:D index or name substring (default: NOVA_DEVICE, else first GPU, "
      "else first CPU)");
}

// Parses `args`; prints the help and returns false when --help was given.
inline bool parse(const Args& args, const po::options_description& desc, po::variables_map& vm,
                  const char* usage_line) {
  po::store(po::command_line_parser(args).options(desc).run(), vm);
  if (vm.count("help")) {
    std::cout << usage_line << "\n\n" << desc << "\n";
    return false;
  }
  po::notify(vm);
  return true;
}

}  // namespace nova::cli

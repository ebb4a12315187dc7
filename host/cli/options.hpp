#pragma once
// Option parsing shared by the subcommands.
#include <boost/program_options.hpp>
#include <iostream>

#include "cli/commands.hpp"
#include "nova/runtime/error.hpp"

namespace nova::cli {

namespace po = boost::program_options;

// Adds --help and --device to `desc`.
inline void add_common_options(po::options_description& desc) {
  desc.add_options()("help,h", "show this help")(
      "device", po::value<std::string>()->default_value(""),
      "OpenCL device: cpu, gpu (the first of that type), P:D index or name substring (default: "
      "NOVA_DEVICE, else first GPU, else first CPU)");
}

// Hard blending (the static blend zeroed where an object blend exceeds 0.5) is what
// composition needs at inference; on the scene's own views it blanks background wherever an
// object's blend field exceeds 0.5 without density (measured: 0.6 dB lower camera-0 PSNR on
// the default synthetic scene), so by default those keep the learnt blend.
inline void add_blend_options(po::options_description& desc) {
  desc.add_options()("soft-blend", po::bool_switch(), "keep the learnt blending everywhere")(
      "hard-blend", po::bool_switch(),
      "hard blending everywhere (default: only for --compose / composition targets)");
}

struct BlendChoice {
  bool scene_views = false;  // hard blending of the scene's own views
  bool composition = true;   // hard blending of composition targets
};

inline BlendChoice blend_choice(const po::variables_map& vm) {
  const bool soft = vm["soft-blend"].as<bool>(), hard = vm["hard-blend"].as<bool>();
  if (soft && hard) throw Error("--soft-blend and --hard-blend exclude each other");
  if (soft) return {false, false};
  if (hard) return {true, true};
  return {};
}

// Parses `args`; prints the help and returns false when --help was given.
inline bool parse(const Args& args, const po::options_description& desc, po::variables_map& vm,
                  const char* usage_line) {
  const po::parsed_options parsed = po::command_line_parser(args).options(desc).run();
  // A word that belongs to no option (a stray value, a misquoted list) is an error, not ignored.
  const std::vector<std::string> stray = po::collect_unrecognized(parsed.options, po::include_positional);
  if (!stray.empty())
    throw Error("unexpected argument '" + stray.front() + "' (every value follows its --option)");
  po::store(parsed, vm);
  if (vm.count("help")) {
    std::cout << usage_line << "\n\n" << desc << "\n";
    return false;
  }
  po::notify(vm);
  return true;
}

}  // namespace nova::cli

// `nova SUBCOMMAND [options]`: dispatch, and one place that turns errors into messages and
// exit codes (2 for anything the user can fix, 1 for internal failures).
#include <boost/program_options/errors.hpp>
#include <cstring>
#include <exception>
#include <iostream>

#include "cli/commands.hpp"
#include "nova/runtime/error.hpp"

namespace nova::cli {

const std::vector<Command>& commands() {
  static const std::vector<Command> all = {
      {"devices", "list OpenCL platforms and devices", devices},
      {"train-mlp", "fit the reference MLP to a smooth 3D function (a runtime smoke test)",
       train_mlp},
      {"scene", "load a scene folder and print its summary and load time", scene},
      {"synth", "write a synthetic NOVA scene with ground truth", synth},
      {"masks", "find what moves in a video: motion masks from frames, poses and disparity", masks},
      {"train", "train a NOVA scene (static pretraining, then joint with augmentation)", train},
      {"render", "render a trained run: any camera, any time, compositions of objects", render},
      {"eval", "PSNR and SSIM of a trained run against the scene's ground truth", eval},
      {"tune", "search GEMM configurations for this device and update the tuning cache", tune},
  };
  return all;
}

}  // namespace nova::cli

namespace {

void usage(std::ostream& os) {
  os << "usage: nova <command> [options]   (nova <command> --help for its options)\n\n"
        "commands:\n";
  for (const auto& c : nova::cli::commands())
    os << "  " << c.name << std::string(12 - std::strlen(c.name), ' ') << c.summary << "\n";
  os << "  --version   print nova's version\n";
  os << "\nThe device is chosen with --device (P:D or a name substring) or NOVA_DEVICE;\n"
        "the default is the first GPU, else the first CPU.\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || !std::strcmp(argv[1], "--help") || !std::strcmp(argv[1], "-h")) {
    usage(argc < 2 ? std::cerr : std::cout);
    return argc < 2 ? nova::kExitUsage : 0;
  }
  const std::string name = argv[1];
  if (name == "--version" || name == "version") {
    std::cout << "nova " << NOVA_VERSION << "\n";
    return 0;
  }
  for (const auto& c : nova::cli::commands()) {
    if (name != c.name) continue;
    try {
      return c.run(nova::cli::Args(argv + 2, argv + argc));
    } catch (const nova::Error& e) {
      std::cerr << "nova " << name << ": error: " << e.what() << "\n";
      return e.exit_code();
    } catch (const boost::program_options::error& e) {
      std::cerr << "nova " << name << ": error: " << e.what() << " (see nova " << name
                << " --help)\n";
      return nova::kExitUsage;
    } catch (const std::exception& e) {
      std::cerr << "nova " << name << ": internal error: " << e.what() << "\n";
      return nova::kExitInternal;
    }
  }
  std::cerr << "nova: unknown command '" << name << "'\n\n";
  usage(std::cerr);
  return nova::kExitUsage;
}

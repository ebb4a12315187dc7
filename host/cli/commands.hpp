#pragma once
// The `nova` subcommands. Each takes the arguments after its name and returns an exit code;
// errors are thrown as nova::Error and reported by main().
#include <string>
#include <vector>

namespace nova::cli {

using Args = std::vector<std::string>;

int devices(const Args& args);
int train_mlp(const Args& args);
int scene(const Args& args);
int synth(const Args& args);
int masks(const Args& args);
int train(const Args& args);
int render(const Args& args);
int eval(const Args& args);
int tune(const Args& args);

struct Command {
  const char* name;
  const char* summary;
  int (*run)(const Args&);
};

// All subcommands, in the order `nova --help` lists them.
const std::vector<Command>& commands();

}  // namespace nova::cli

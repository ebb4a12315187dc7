#pragma once
// `--key value` and `--flag` parsing for nova-bench (which links no Boost, so that a GPU
// machine without packages can build it from the core alone).
#include <map>
#include <string>
#include <vector>

namespace nova::bench {

// Takes every `--option VALUE` of a repeatable option out of `args` (before Options parses
// the single-valued rest) and returns the values in order. Error naming `value_hint` when the
// last one has no value.
std::vector<std::string> take_repeated(std::vector<std::string>& args, const std::string& option,
                                       const std::string& value_hint);

class Options {
 public:
  // `defaults` names every option; a default of "off" or "on" makes it a flag. Error naming
  // the argument on an unknown option, a stray argument or a missing value.
  Options(const std::vector<std::string>& args, const std::map<std::string, std::string>& defaults);
  // --help was given: print usage() and stop.
  bool help() const { return help_; }
  std::string usage(const std::string& command) const;
  std::string str(const std::string& k) const { return values_.at(k); }
  bool flag(const std::string& k) const { return values_.at(k) == "on"; }
  long integer(const std::string& k) const;
  // A comma-separated list, empty items dropped.
  std::vector<std::string> strings(const std::string& k) const;
  std::vector<long> integers(const std::string& k) const;

 private:
  std::map<std::string, std::string> values_;
  bool help_ = false;
};

}  // namespace nova::bench

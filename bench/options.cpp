// nova-bench's option parsing (bench/options.hpp).
#include "options.hpp"

#include <sstream>

#include "nova/runtime/error.hpp"

namespace nova::bench {

std::vector<std::string> take_repeated(std::vector<std::string>& args, const std::string& option,
                                       const std::string& value_hint) {
  const std::string flag = "--" + option;
  std::vector<std::string> rest, values;
  for (size_t i = 0; i < args.size(); ++i) {
    if (args[i] == flag) {
      if (i + 1 >= args.size()) throw Error(flag + " needs a value (" + value_hint + ")");
      values.push_back(args[++i]);
    } else {
      rest.push_back(args[i]);
    }
  }
  args = std::move(rest);
  return values;
}

Options::Options(const std::vector<std::string>& args, const std::map<std::string, std::string>& defaults)
    : values_(defaults) {
  for (size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--help" || args[i] == "-h") {
      help_ = true;
      continue;
    }
    if (args[i].rfind("--", 0) != 0) throw Error("unexpected argument '" + args[i] + "'");
    const std::string key = args[i].substr(2);
    if (!values_.count(key)) throw Error("unknown option --" + key);
    const bool is_flag = values_[key] == "off" || values_[key] == "on";
    if (is_flag) {
      values_[key] = "on";
    } else {
      if (i + 1 >= args.size()) throw Error("--" + key + " needs a value");
      values_[key] = args[++i];
    }
  }
}

std::string Options::usage(const std::string& command) const {
  std::string u = "usage: " + command + " [options]\n\noptions (default):\n";
  for (const auto& [k, v] : values_) u += "  --" + k + " (" + (v.empty() ? "none" : v) + ")\n";
  return u;
}

long Options::integer(const std::string& k) const {
  try {
    return std::stol(values_.at(k));
  } catch (const std::exception&) {
    throw Error("--" + k + " must be an integer, got '" + values_.at(k) + "'");
  }
}

std::vector<std::string> Options::strings(const std::string& k) const {
  std::vector<std::string> out;
  std::stringstream s(values_.at(k));
  for (std::string item; std::getline(s, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

std::vector<long> Options::integers(const std::string& k) const {
  std::vector<long> out;
  std::stringstream s(values_.at(k));
  for (std::string item; std::getline(s, item, ',');) {
    try {
      out.push_back(std::stol(item));
    } catch (const std::exception&) {
      throw Error("--" + k + " must be a comma-separated list of integers");
    }
  }
  return out;
}

}  // namespace nova::bench

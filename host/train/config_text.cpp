// config.ini: a TrainConfig as `key = value` lines and back.
#include <algorithm>
#include <sstream>

#include "nova/runtime/error.hpp"
#include "nova/train/train_config.hpp"
#include "train/config_trim.hpp"

namespace nova {

using detail::trim;

std::string format_config(const TrainConfig& c, const std::vector<std::string>& extra) {
  std::ostringstream s;
  s << "# nova train configuration (key = value; every key is a `nova train` option)\n";
  for (const ConfigOption& o : config_options()) s << "# " << o.help << "\n" << o.key << " = " << o.get(c) << "\n";
  for (const std::string& line : extra) s << line << "\n";
  return s.str();
}

TrainConfig parse_config_text(const std::string& text, const std::string& origin,
                              std::vector<std::pair<std::string, std::string>>* others, ConfigFile kind) {
  std::vector<std::pair<std::string, std::string>> entries;
  std::istringstream in(text);
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    const std::string t = trim(line.substr(0, line.find('#')));
    if (t.empty()) continue;
    const size_t eq = t.find('=');
    if (eq == std::string::npos)
      throw Error(origin + ":" + std::to_string(number) + ": expected 'key = value', got '" + t + "'");
    entries.emplace_back(trim(t.substr(0, eq)), trim(t.substr(eq + 1)));
  }
  TrainConfig c = preset_config("quick");
  for (const auto& [k, v] : entries)  // the preset first: every other key overrides it
    if (k == "preset") c = preset_config(v);
  for (const auto& [k, v] : entries) {
    if (k == "preset") continue;
    bool known = false;
    for (const ConfigOption& o : config_options())
      if (o.key == k) {
        try {
          o.set(c, v);
        } catch (const Error& e) {
          throw Error(origin + ": " + e.what());
        }
        known = true;
      }
    if (!known) {
      if (!others) throw Error(origin + ": unknown option '" + k + "'");
      others->emplace_back(k, v);
    }
  }
  if (kind == ConfigFile::RunFile)
    for (const ConfigOption& o : config_options()) {
      const bool written = std::any_of(entries.begin(), entries.end(), [&](const auto& e) { return e.first == o.key; });
      if (!written && !o.before.empty()) o.set(c, o.before);
    }
  return c;
}

}  // namespace nova

// The composition spec text format (see include/nova/io/compose_spec_text.hpp): parser and
// writer.
#include "nova/io/compose_spec_text.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include "nova/runtime/error.hpp"
#include "runtime/parse_number.hpp"
#include "runtime/read_file.hpp"

namespace nova {
namespace {

[[noreturn]] void fail(const std::string& origin, int line, const std::string& what) {
  throw Error(origin + ":" + std::to_string(line) + ": " + what);
}

double parse_number(const std::string& s, const std::string& origin, int line,
                    const std::string& key) {
  const std::optional<double> v = parse_whole_double(s);
  if (!v || !std::isfinite(*v)) fail(origin, line, "'" + key + "' needs a finite number, got '" + s + "'");
  return *v;
}

std::array<double, 3> parse_triple(const std::string& s, const std::string& origin, int line,
                                   const std::string& key) {
  std::array<double, 3> out{};
  std::stringstream ss(s);
  std::string part;
  int n = 0;
  while (std::getline(ss, part, ',')) {
    if (n == 3) break;
    out[n++] = parse_number(part, origin, line, key);
  }
  if (n != 3 || !ss.eof() || (!s.empty() && s.back() == ','))
    fail(origin, line, "'" + key + "' needs three comma-separated numbers, got '" + s + "'");
  return out;
}

int parse_int(const std::string& s, const std::string& origin, int line,
              const std::string& key) {
  const std::optional<long> v = parse_whole_long(s);
  // std::stoi's range: an int, not a long.
  if (!v || *v < std::numeric_limits<int>::min() || *v > std::numeric_limits<int>::max())
    fail(origin, line, "'" + key + "' needs an integer, got '" + s + "'");
  return static_cast<int>(*v);
}

bool plain_word(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.'))
      return false;
  return true;
}

// Splits "key=value" tokens; every key must be in `allowed`.
std::vector<std::pair<std::string, std::string>> key_values(std::istringstream& in,
                                                            const std::string& origin,
                                                            int line) {
  std::vector<std::pair<std::string, std::string>> kv;
  std::string tok;
  while (in >> tok) {
    const auto eq = tok.find('=');
    if (eq == std::string::npos || eq == 0)
      fail(origin, line, "expected key=value, got '" + tok + "'");
    kv.emplace_back(tok.substr(0, eq), tok.substr(eq + 1));
  }
  return kv;
}

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string triple(const std::array<double, 3>& v) {
  return num(v[0]) + "," + num(v[1]) + "," + num(v[2]);
}

}  // namespace

ComposeSpec parse_compose_spec(const std::string& text, const std::string& origin) {
  ComposeSpec spec;
  std::istringstream all(text);
  std::string raw;
  int line = 0;
  bool header = false;
  while (std::getline(all, raw)) {
    ++line;
    const auto hash = raw.find('#');
    if (hash != std::string::npos) raw.resize(hash);
    std::istringstream in(raw);
    std::string word;
    if (!(in >> word)) continue;
    if (!header) {
      std::string version;
      in >> version;
      if (word != "nova-compose" || version != "1")
        fail(origin, line, "expected the header 'nova-compose 1'");
      header = true;
      continue;
    }
    if (word == "target") {
      ComposeTarget t;
      if (!(in >> t.name) || !plain_word(t.name) || t.name.find('=') != std::string::npos)
        fail(origin, line, "'target' needs a plain name (letters, digits, _ - .)");
      bool have_camera = false;
      for (const auto& [k, v] : key_values(in, origin, line)) {
        if (k == "camera") {
          t.camera = parse_int(v, origin, line, k);
          if (t.camera < 0) fail(origin, line, "camera must be >= 0");
          have_camera = true;
        } else if (k == "background") {
          if (v != "0" && v != "1") fail(origin, line, "background must be 0 or 1");
          t.background = v == "1";
        } else {
          fail(origin, line, "unknown target key '" + k + "'");
        }
      }
      if (!have_camera) fail(origin, line, "target '" + t.name + "' needs camera=FRAME");
      for (const auto& other : spec.targets)
        if (other.name == t.name) fail(origin, line, "duplicate target '" + t.name + "'");
      spec.targets.push_back(std::move(t));
    } else if (word == "instance") {
      if (spec.targets.empty()) fail(origin, line, "'instance' before any 'target'");
      ComposeInstance inst;
      bool have_object = false, have_time = false;
      for (const auto& [k, v] : key_values(in, origin, line)) {
        if (k == "object") {
          inst.object = parse_int(v, origin, line, k);
          if (inst.object < 1) fail(origin, line, "object must be >= 1 (0 is the background)");
          have_object = true;
        } else if (k == "time") {
          inst.time = parse_number(v, origin, line, k);
          // The range nova render's --time takes: the object NeRFs know no other times.
          if (!(inst.time >= -1.0 && inst.time <= 1.0))
            fail(origin, line, "time must be in [-1, 1] (frame i of N has 2i/N - 1), got " + v);
          have_time = true;
        } else if (k == "rotate") {
          inst.rotate_deg = parse_triple(v, origin, line, k);
        } else if (k == "translate") {
          inst.translate = parse_triple(v, origin, line, k);
        } else if (k == "pivot") {
          inst.pivot = parse_triple(v, origin, line, k);
        } else {
          fail(origin, line, "unknown instance key '" + k + "'");
        }
      }
      if (!have_object || !have_time) fail(origin, line, "instance needs object= and time=");
      spec.targets.back().instances.push_back(inst);
    } else {
      fail(origin, line, "unknown statement '" + word + "' (expected target or instance)");
    }
  }
  if (!header) throw Error(origin + ": empty compose spec (expected 'nova-compose 1')");
  return spec;
}

ComposeSpec read_compose_spec(const std::string& path) {
  const std::optional<std::string> text = read_file(path);
  if (!text) throw Error(path + ": cannot open compose spec");
  return parse_compose_spec(*text, path);
}

std::string format_compose_spec(const ComposeSpec& spec) {
  std::string out =
      "nova-compose 1\n"
      "# p' = R (p - pivot) + pivot + translate, R = Rz Ry Rx (degrees), scene coordinates\n";
  for (const auto& t : spec.targets) {
    out += "target " + t.name + " camera=" + std::to_string(t.camera) +
           " background=" + (t.background ? "1" : "0") + "\n";
    for (const auto& i : t.instances)
      out += "instance object=" + std::to_string(i.object) + " time=" + num(i.time) +
             " rotate=" + triple(i.rotate_deg) + " translate=" + triple(i.translate) +
             (i.pivot ? " pivot=" + triple(*i.pivot) : std::string()) + "\n";
  }
  return out;
}

}  // namespace nova

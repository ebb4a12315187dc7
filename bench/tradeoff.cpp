// The device-free pieces of `nova-bench tradeoff` (bench/tradeoff.hpp).
#include "tradeoff.hpp"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <set>
#include <sstream>

#include "nova/runtime/error.hpp"
#include "nova/ops/linalg/gemm.hpp"
#include "nova/io/charts.hpp"
#include "nova/train/train_config.hpp"

namespace nova::tradeoff {

std::string trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r\n");
  if (a == std::string::npos) return "";
  return s.substr(a, s.find_last_not_of(" \t\r\n") - a + 1);
}

Setting parse_setting(const std::string& text, const std::string& origin) {
  const std::string spec = trim(text);
  const size_t colon = spec.find(':');
  Setting s;
  s.name = trim(spec.substr(0, colon));
  const auto bad = [&](const std::string& why) {
    return Error(origin + " '" + spec + "': " + why +
                 " (expected NAME:KEY=VALUE,KEY=VALUE, e.g. samples-64:samples=64)");
  };
  if (s.name.empty()) throw bad("the setting has no name");
  for (char c : s.name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '_' && c != '+' && c != '-')
      throw bad("the name '" + s.name + "' may hold only letters, digits, '.', '_', '+' and '-'");
  if (colon == std::string::npos) return s;
  std::stringstream items(spec.substr(colon + 1));
  for (std::string item; std::getline(items, item, ',');) {
    item = trim(item);
    if (item.empty()) continue;
    const size_t eq = item.find('=');
    if (eq == std::string::npos) throw bad("'" + item + "' is not KEY=VALUE");
    std::string key = trim(item.substr(0, eq)), value = trim(item.substr(eq + 1));
    if (key.empty() || value.empty()) throw bad("'" + item + "' is not KEY=VALUE");
    if (key.rfind("--", 0) == 0) key = key.substr(2);
    if (key == "gemm" || key == "NOVA_GEMM") {
      try {
        parse_gemm_provider(value, "GEMM provider");
      } catch (const Error& e) {
        throw bad(e.what());
      }
      s.gemm = value;
      continue;
    }
    s.overrides.emplace_back(key, value);
  }
  return s;
}

std::vector<Setting> parse_settings_text(const std::string& text, const std::string& origin) {
  std::vector<Setting> out;
  std::stringstream lines(text);
  int n = 0;
  for (std::string line; std::getline(lines, line);) {
    ++n;
    line = trim(line.substr(0, line.find('#')));
    if (line.empty()) continue;
    out.push_back(parse_setting(line, origin + ":" + std::to_string(n)));
  }
  if (out.empty()) throw Error(origin + ": no settings in it");
  return out;
}

void check_unique_names(const std::vector<Setting>& settings) {
  std::set<std::string> seen;
  for (const Setting& s : settings)
    if (!seen.insert(s.name).second) throw Error("setting name '" + s.name + "' is given twice");
}

std::vector<Setting> default_settings() {
  return parse_settings_text(
      "quick\n"
      "samples-32:  samples=32\n"
      "samples-64:  samples=64\n"
      "samples-128: samples=128\n"
      "width-64:    width=64\n"
      "width-128:   width=128\n"
      "width-256:   width=256\n"
      "gemm-tuned:  gemm=tuned\n"
      "gemm-clblast: gemm=clblast\n"
      "gemm-kernels: gemm=kernels\n"
      "skip-on:     occupancy=true\n"
      "skip-off:    occupancy=false\n",
      "default settings");
}

std::vector<std::string> unknown_keys(const Setting& s) {
  std::vector<std::string> out;
  for (const auto& [key, value] : s.overrides) {
    bool known = false;
    for (const ConfigOption& o : config_options()) known = known || o.key == key;
    if (!known) out.push_back(key);
  }
  return out;
}

Budget parse_budget(const std::string& text) {
  Budget b;
  const std::string t = trim(text);
  const bool secs = !t.empty() && t.back() == 's';
  const std::string num = secs ? t.substr(0, t.size() - 1) : t;
  double v = 0;
  size_t used = 0;
  try {
    v = std::stod(num, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (num.empty() || used != num.size() || !(v > 0) || !std::isfinite(v))
    throw Error("--budget '" + text + "' is neither a positive scale of the schedule (1, 0.5) nor seconds (300s)");
  (secs ? b.seconds : b.scale) = v;
  return b;
}

std::vector<long> segment_ends(long pretrain, long joint, int segments) {
  std::vector<long> out;
  const auto push = [&](long s) {
    if (s > 0 && (out.empty() || s > out.back())) out.push_back(s);
  };
  if (joint <= 0) {
    for (int i = 1; i <= segments; ++i) push(std::lround(double(pretrain) * i / segments));
    return out;
  }
  push(pretrain);
  for (int i = 1; i <= segments; ++i) push(pretrain + std::lround(double(joint) * i / segments));
  return out;
}

std::vector<int> spread_indices(int n, int count) {
  std::vector<int> out;
  if (n <= 0 || count <= 0) return out;
  if (count >= n || count == 1) {
    for (int i = 0; i < (count == 1 ? 1 : n); ++i) out.push_back(i);
    return out;
  }
  for (int i = 0; i < count; ++i) {
    const int k = static_cast<int>(std::lround(double(n - 1) * i / (count - 1)));
    if (out.empty() || k > out.back()) out.push_back(k);
  }
  return out;
}

std::optional<double> time_to_reach(const std::vector<Point>& points, double level) {
  for (size_t i = 0; i < points.size(); ++i) {
    if (!(points[i].psnr >= level)) continue;
    if (i == 0) return points[0].seconds;
    const Point &a = points[i - 1], &b = points[i];
    const double f = (level - a.psnr) / (b.psnr - a.psnr);  // a.psnr < level <= b.psnr
    return a.seconds + f * (b.seconds - a.seconds);
  }
  return std::nullopt;
}

std::optional<double> speedup_at(const Curve& base, const Curve& other, double level) {
  const auto tb = time_to_reach(base.points, level), to = time_to_reach(other.points, level);
  if (!tb || !to || !(*to > 0)) return std::nullopt;
  return *tb / *to;
}

std::string fmt(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

std::string csv_text(const std::vector<Curve>& curves) {
  std::string out = "setting,run,segment,steps,train_seconds,psnr,ssim,rays_per_s\n";
  for (const Curve& c : curves)
    for (const Point& p : c.points)
      out += c.setting + "," + c.run + "," + std::to_string(p.segment) + "," + std::to_string(p.steps) + "," +
             fmt(p.seconds, 3) + "," + fmt(p.psnr, 4) + "," + fmt(p.ssim, 5) + "," + fmt(p.rays_per_s, 1) + "\n";
  return out;
}

Image8 plot(const std::vector<Series>& series, const std::string& title, double level,
            int width, int height) {
  std::vector<ScatterGroup> curves;
  for (const Series& s : series) curves.push_back({s.label, s.xy, {}});
  XYChart chart;
  chart.title = title;
  chart.x_label = "training time (s, evaluation excluded)";
  chart.y_label = "PSNR (dB)";
  chart.lines = true;
  chart.marker = 4;
  chart.legend_bottom = true;  // the curves rise to the top left
  chart.level = level;
  chart.level_label = "equal-PSNR level " + fmt(level, 2) + " dB";
  return plot_xy(curves, chart, width, height);
}

}  // namespace nova::tradeoff

// The device-free pieces of `nova-bench tradeoff` (bench/tradeoff.hpp).
#include "tradeoff.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdio>
#include <set>
#include <sstream>

#include <opencv2/imgproc.hpp>

#include "nova/error.hpp"
#include "nova/gemm.hpp"
#include "nova/io/visualize.hpp"
#include "nova/train_config.hpp"

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
  // Tableau 10, as BGR.
  static const std::array<cv::Scalar, 10> colours = {
      cv::Scalar(180, 119, 31), cv::Scalar(14, 127, 255), cv::Scalar(44, 160, 44), cv::Scalar(40, 39, 214),
      cv::Scalar(189, 103, 148), cv::Scalar(75, 86, 140), cv::Scalar(194, 119, 227), cv::Scalar(127, 127, 127),
      cv::Scalar(34, 189, 188), cv::Scalar(207, 190, 23)};
  cv::Mat img(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  const cv::Scalar black(0, 0, 0), grid(225, 225, 225);
  const int left = 80, right = width - 30, top = 50, bottom = height - 70;

  double x1 = 0, y0 = INFINITY, y1 = -INFINITY;
  for (const Series& s : series)
    for (auto [x, y] : s.xy) {
      if (!std::isfinite(x) || !std::isfinite(y)) continue;
      x1 = std::max(x1, x);
      y0 = std::min(y0, y);
      y1 = std::max(y1, y);
    }
  if (std::isfinite(level)) y0 = std::min(y0, level), y1 = std::max(y1, level);
  if (!std::isfinite(y0)) y0 = 0, y1 = 1;
  if (!(x1 > 0)) x1 = 1;
  const double pad = std::max(0.5, (y1 - y0) * 0.05);
  y0 -= pad;
  y1 += pad;
  double xstep = 1, ystep = 1;
  const std::vector<double> xt = axis_ticks(0, x1, 6, &xstep), yt = axis_ticks(y0, y1, 6, &ystep);
  x1 = std::max(x1, xt.back());
  y0 = std::min(y0, yt.front());
  y1 = std::max(y1, yt.back());
  const auto px = [&](double x) { return static_cast<int>(std::lround(left + (right - left) * x / x1)); };
  const auto py = [&](double y) { return static_cast<int>(std::lround(bottom - (bottom - top) * (y - y0) / (y1 - y0))); };

  for (double x : xt) {
    cv::line(img, {px(x), top}, {px(x), bottom}, grid, 1);
    cv::line(img, {px(x), bottom}, {px(x), bottom + 5}, black, 1);
    const std::string t = axis_tick_text(x, xstep);
    int base = 0;
    const cv::Size sz = cv::getTextSize(t, font, 0.45, 1, &base);
    cv::putText(img, t, {px(x) - sz.width / 2, bottom + 22}, font, 0.45, black, 1, cv::LINE_AA);
  }
  for (double y : yt) {
    cv::line(img, {left, py(y)}, {right, py(y)}, grid, 1);
    cv::line(img, {left - 5, py(y)}, {left, py(y)}, black, 1);
    const std::string t = axis_tick_text(y, ystep);
    int base = 0;
    const cv::Size sz = cv::getTextSize(t, font, 0.45, 1, &base);
    cv::putText(img, t, {left - 9 - sz.width, py(y) + sz.height / 2}, font, 0.45, black, 1, cv::LINE_AA);
  }
  cv::rectangle(img, {left, top}, {right, bottom}, black, 1);
  {
    int base = 0;
    const std::string xl = "training time (s, evaluation excluded)";
    const cv::Size sz = cv::getTextSize(xl, font, 0.55, 1, &base);
    cv::putText(img, xl, {(left + right - sz.width) / 2, height - 22}, font, 0.55, black, 1, cv::LINE_AA);
    const std::string yl = "PSNR (dB)";
    const cv::Size ys = cv::getTextSize(yl, font, 0.55, 1, &base);
    cv::Mat label(ys.height + base + 4, ys.width + 4, CV_8UC3, cv::Scalar(255, 255, 255));
    cv::putText(label, yl, {2, ys.height + 1}, font, 0.55, black, 1, cv::LINE_AA);
    cv::Mat rotated;
    cv::rotate(label, rotated, cv::ROTATE_90_COUNTERCLOCKWISE);
    const int ry = std::max(0, (top + bottom - rotated.rows) / 2);
    if (ry + rotated.rows <= height && 8 + rotated.cols <= width) rotated.copyTo(img(cv::Rect(8, ry, rotated.cols, rotated.rows)));
    const cv::Size ts = cv::getTextSize(title, font, 0.6, 1, &base);
    cv::putText(img, title, {std::max(4, (width - ts.width) / 2), 30}, font, 0.6, black, 1, cv::LINE_AA);
  }
  if (std::isfinite(level)) {
    for (int x = left; x < right; x += 12) cv::line(img, {x, py(level)}, {std::min(x + 6, right), py(level)}, black, 1);
  }

  for (size_t i = 0; i < series.size(); ++i) {
    const cv::Scalar c = colours[i % colours.size()];
    std::vector<cv::Point> pts;
    for (auto [x, y] : series[i].xy)
      if (std::isfinite(x) && std::isfinite(y)) pts.emplace_back(px(x), py(y));
    if (pts.size() > 1) cv::polylines(img, pts, false, c, 2, cv::LINE_AA);
    for (const cv::Point& p : pts) {
      if (i / colours.size() % 2 == 0)
        cv::circle(img, p, 4, c, cv::FILLED, cv::LINE_AA);
      else  // an eleventh series and on: square markers
        cv::rectangle(img, {p.x - 4, p.y - 4}, {p.x + 4, p.y + 4}, c, cv::FILLED);
    }
  }
  // Legend, bottom right (the curves rise to the top left), with the level's dashed line.
  const std::string level_label = std::isfinite(level) ? "equal-PSNR level " + fmt(level, 2) + " dB" : "";
  int lw = 0, lh = 0, base = 0;
  for (const Series& s : series) {
    const cv::Size sz = cv::getTextSize(s.label, font, 0.45, 1, &base);
    lw = std::max(lw, sz.width);
    lh = std::max(lh, sz.height + base);
  }
  if (!level_label.empty()) lw = std::max(lw, cv::getTextSize(level_label, font, 0.45, 1, &base).width);
  const int rows = static_cast<int>(series.size()) + (level_label.empty() ? 0 : 1);
  const int row = std::max(lh, 12) + 6, bw = lw + 50, bh = row * rows + 10;
  const int bx = right - bw - 10, by = bottom - bh - 10;
  if (!series.empty() && bx > left && by > top) {
    cv::rectangle(img, {bx, by}, {bx + bw, by + bh}, cv::Scalar(255, 255, 255), cv::FILLED);
    cv::rectangle(img, {bx, by}, {bx + bw, by + bh}, cv::Scalar(160, 160, 160), 1);
    for (size_t i = 0; i < series.size(); ++i) {
      const cv::Scalar c = colours[i % colours.size()];
      const int y = by + 5 + row * static_cast<int>(i) + row / 2;
      cv::line(img, {bx + 8, y}, {bx + 36, y}, c, 2, cv::LINE_AA);
      cv::circle(img, {bx + 22, y}, 4, c, cv::FILLED, cv::LINE_AA);
      cv::putText(img, series[i].label, {bx + 44, y + lh / 2 - base}, font, 0.45, black, 1, cv::LINE_AA);
    }
    if (!level_label.empty()) {
      const int y = by + 5 + row * static_cast<int>(series.size()) + row / 2;
      for (int x = bx + 8; x < bx + 36; x += 12) cv::line(img, {x, y}, {std::min(x + 6, bx + 36), y}, black, 1);
      cv::putText(img, level_label, {bx + 44, y + lh / 2 - base}, font, 0.45, black, 1, cv::LINE_AA);
    }
  }
  Image8 out(width, height, 3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const cv::Vec3b v = img.at<cv::Vec3b>(y, x);
      out.at(x, y, 0) = v[2];
      out.at(x, y, 1) = v[1];
      out.at(x, y, 2) = v[0];
    }
  return out;
}

}  // namespace nova::tradeoff

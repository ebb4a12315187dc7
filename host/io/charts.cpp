// Charts and picture sheets (RGB, white background, Tableau 10 colours), drawn with OpenCV.
#include "nova/io/charts.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgproc.hpp>
#include <string>

#include "nova/runtime/error.hpp"

namespace nova {
namespace {

// Tableau 10, as BGR.
const cv::Scalar kColours[10] = {
    cv::Scalar(180, 119, 31), cv::Scalar(14, 127, 255), cv::Scalar(44, 160, 44), cv::Scalar(40, 39, 214),
    cv::Scalar(189, 103, 148), cv::Scalar(75, 86, 140), cv::Scalar(194, 119, 227), cv::Scalar(127, 127, 127),
    cv::Scalar(34, 189, 188), cv::Scalar(207, 190, 23)};
const int kFont = cv::FONT_HERSHEY_SIMPLEX;

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}


Image8 from_bgr(const cv::Mat& img) {
  Image8 out(img.cols, img.rows, 3);
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x) {
      const cv::Vec3b v = img.at<cv::Vec3b>(y, x);
      out.at(x, y, 0) = v[2];
      out.at(x, y, 1) = v[1];
      out.at(x, y, 2) = v[0];
    }
  return out;
}

// Text centred on cx, shrunk (down to 60%) to fit the image's width.
void centred_text(cv::Mat& img, const std::string& t, int cx, int y, double scale, const cv::Scalar& c) {
  int base = 0;
  cv::Size sz = cv::getTextSize(t, kFont, scale, 1, &base);
  for (const double smallest = scale * 0.6; sz.width > img.cols - 8 && scale > smallest;) {
    scale *= 0.95;
    sz = cv::getTextSize(t, kFont, scale, 1, &base);
  }
  cv::putText(img, t, {std::max(2, std::min(cx - sz.width / 2, img.cols - 2 - sz.width)), y}, kFont, scale, c, 1,
              cv::LINE_AA);
}

// Axes frame: title, y label (rotated), x label, y ticks over [y0, y1] with grid lines.
struct Frame2D {
  int left, right, top, bottom;
  double y0, y1;
  int py(double y) const { return static_cast<int>(std::lround(bottom - (bottom - top) * (y - y0) / (y1 - y0))); }
};

void draw_y_axis(cv::Mat& img, const Frame2D& f, const std::vector<double>& yt, double ystep) {
  const cv::Scalar black(0, 0, 0), grid(225, 225, 225);
  for (double y : yt) {
    cv::line(img, {f.left, f.py(y)}, {f.right, f.py(y)}, grid, 1);
    cv::line(img, {f.left - 5, f.py(y)}, {f.left, f.py(y)}, black, 1);
    const std::string t = axis_tick_text(y, ystep);
    int base = 0;
    const cv::Size sz = cv::getTextSize(t, kFont, 0.45, 1, &base);
    cv::putText(img, t, {f.left - 9 - sz.width, f.py(y) + sz.height / 2}, kFont, 0.45, black, 1, cv::LINE_AA);
  }
}

void draw_labels(cv::Mat& img, const Frame2D& f, const std::string& title, const std::string& x_label,
                 const std::string& y_label) {
  const cv::Scalar black(0, 0, 0);
  centred_text(img, title, img.cols / 2, 28, 0.6, black);
  if (!x_label.empty()) centred_text(img, x_label, (f.left + f.right) / 2, img.rows - 12, 0.55, black);
  if (!y_label.empty()) {
    int base = 0;
    const cv::Size ys = cv::getTextSize(y_label, kFont, 0.55, 1, &base);
    cv::Mat label(ys.height + base + 4, ys.width + 4, CV_8UC3, cv::Scalar(255, 255, 255));
    cv::putText(label, y_label, {2, ys.height + 1}, kFont, 0.55, black, 1, cv::LINE_AA);
    cv::Mat rotated;
    cv::rotate(label, rotated, cv::ROTATE_90_COUNTERCLOCKWISE);
    const int ry = std::max(0, (f.top + f.bottom - rotated.rows) / 2);
    if (ry + rotated.rows <= img.rows && 6 + rotated.cols <= img.cols)
      rotated.copyTo(img(cv::Rect(6, ry, rotated.cols, rotated.rows)));
  }
}

cv::Mat to_bgr(const Image8& im) {
  if (im.empty() || (im.channels != 1 && im.channels != 3)) throw Error("image_row: an image is empty or not grey/RGB");
  cv::Mat out(im.height, im.width, CV_8UC3);
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const uint8_t r = im.at(x, y, 0), g = im.at(x, y, im.channels == 3 ? 1 : 0),
                    b = im.at(x, y, im.channels == 3 ? 2 : 0);
      out.at<cv::Vec3b>(y, x) = cv::Vec3b(b, g, r);
    }
  return out;
}

}  // namespace

std::vector<double> axis_ticks(double lo, double hi, int target, double* step_out) {
  if (!(hi > lo)) hi = lo + 1;
  const double raw = (hi - lo) / target, mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = 10 * mag;
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (raw <= m * mag) {
      step = m * mag;
      break;
    }
  std::vector<double> out;
  for (double v = std::ceil(lo / step - 1e-9) * step; v <= hi + step * 1e-9; v += step)
    out.push_back(std::abs(v) < step * 1e-9 ? 0.0 : v);
  *step_out = step;
  return out;
}

std::string axis_tick_text(double v, double step) {
  return fixed(v, step >= 1 ? 0 : static_cast<int>(std::ceil(-std::log10(step) - 1e-9)));
}

Image8 plot_bar_groups(const std::vector<BarGroup>& groups, const std::string& title, const std::string& y_label,
                       int decimals, int width, int height) {
  cv::Mat img(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  const cv::Scalar black(0, 0, 0);
  double vmax = 0;
  size_t bars = 0;
  for (const BarGroup& g : groups)
    for (const auto& [name, v] : g.bars) {
      ++bars;
      if (std::isfinite(v)) vmax = std::max(vmax, v);
    }
  double ystep = 1;
  const std::vector<double> yt = axis_ticks(0, vmax > 0 ? vmax * 1.08 : 1, 6, &ystep);
  Frame2D f{70, width - 20, 45, height - 75, 0, std::max(yt.back(), vmax * 1.08)};
  if (!(f.y1 > 0)) f.y1 = 1;
  draw_y_axis(img, f, yt, ystep);
  // Slots: one per bar, plus one empty slot between groups.
  const size_t slots = std::max<size_t>(1, bars + (groups.empty() ? 0 : groups.size() - 1));
  const double slot = double(f.right - f.left) / slots;
  size_t k = 0;
  for (size_t gi = 0; gi < groups.size(); ++gi) {
    const cv::Scalar c = kColours[gi % 10];
    const size_t first = k;
    for (const auto& [name, v] : groups[gi].bars) {
      // Bars at most 80 pixels wide, centred in their slot.
      const int cx = static_cast<int>(f.left + slot * (k + 0.5)), half = static_cast<int>(std::min(slot * 0.35, 40.0));
      const int x0 = cx - half, x1 = cx + half;
      if (std::isfinite(v) && v > 0) {
        cv::rectangle(img, {x0, f.py(v)}, {x1, f.bottom}, c, cv::FILLED);
        centred_text(img, fixed(v, decimals), cx, f.py(v) - 5, 0.4, black);
      } else {
        centred_text(img, std::isfinite(v) ? fixed(v, decimals) : "n/a", cx, f.bottom - 5, 0.4, black);
      }
      centred_text(img, name, cx, f.bottom + 18, 0.4, black);
      ++k;
    }
    if (k > first) {
      const int a = static_cast<int>(f.left + slot * first), b = static_cast<int>(f.left + slot * k);
      cv::line(img, {a + 4, f.bottom + 27}, {b - 4, f.bottom + 27}, c, 2);
      centred_text(img, groups[gi].label, (a + b) / 2, f.bottom + 45, 0.5, c);
    }
    ++k;  // the gap between groups
  }
  cv::rectangle(img, {f.left, f.top}, {f.right, f.bottom}, black, 1);
  draw_labels(img, f, title, "", y_label);
  return from_bgr(img);
}

Image8 plot_xy(const std::vector<ScatterGroup>& series, const XYChart& chart, int width, int height) {
  cv::Mat img(height, width, CV_8UC3, cv::Scalar(255, 255, 255));
  const cv::Scalar black(0, 0, 0), grid(225, 225, 225);
  const bool level = std::isfinite(chart.level);
  double x1 = 0, y0 = INFINITY, y1 = -INFINITY;
  for (const ScatterGroup& g : series)
    for (auto [x, y] : g.xy) {
      if (!std::isfinite(x) || !std::isfinite(y)) continue;
      x1 = std::max(x1, x);
      y0 = std::min(y0, y);
      y1 = std::max(y1, y);
    }
  if (level) y0 = std::min(y0, chart.level), y1 = std::max(y1, chart.level);
  if (!std::isfinite(y0)) y0 = 0, y1 = 1;
  const double pad = std::max(0.5, (y1 - y0) * 0.08);
  double xstep = 1, ystep = 1;
  const std::vector<double> xt = axis_ticks(0, x1 > 0 ? x1 * 1.05 : 1, 6, &xstep), yt = axis_ticks(y0 - pad, y1 + pad, 6, &ystep);
  Frame2D f{70, width - 20, 45, height - 55, std::min(y0 - pad, yt.front()), std::max(y1 + pad, yt.back())};
  const double xmax = std::max(xt.back(), x1 > 0 ? x1 * 1.05 : 1);
  const auto px = [&](double x) { return static_cast<int>(std::lround(f.left + (f.right - f.left) * x / xmax)); };
  draw_y_axis(img, f, yt, ystep);
  for (double x : xt) {
    cv::line(img, {px(x), f.top}, {px(x), f.bottom}, grid, 1);
    cv::line(img, {px(x), f.bottom}, {px(x), f.bottom + 5}, black, 1);
    centred_text(img, axis_tick_text(x, xstep), px(x), f.bottom + 20, 0.45, black);
  }
  cv::rectangle(img, {f.left, f.top}, {f.right, f.bottom}, black, 1);
  const auto dashes = [&](int from, int to, int y) {
    for (int x = from; x < to; x += 12) cv::line(img, {x, y}, {std::min(x + 6, to), y}, black, 1);
  };
  if (level) dashes(f.left, f.right, f.py(chart.level));
  // A series' marker: circles, from the eleventh series on squares.
  const auto marker = [&](size_t gi, cv::Point p) {
    const cv::Scalar c = kColours[gi % 10];
    const int r = chart.marker;
    if (gi / 10 % 2 == 0)
      cv::circle(img, p, r, c, cv::FILLED, cv::LINE_AA);
    else
      cv::rectangle(img, {p.x - r, p.y - r}, {p.x + r, p.y + r}, c, cv::FILLED);
  };
  for (size_t gi = 0; gi < series.size(); ++gi) {
    std::vector<cv::Point> line;
    for (auto [x, y] : series[gi].xy)
      if (std::isfinite(x) && std::isfinite(y)) line.emplace_back(px(x), f.py(y));
    if (chart.lines && line.size() > 1) cv::polylines(img, line, false, kColours[gi % 10], 2, cv::LINE_AA);
    for (size_t i = 0; i < series[gi].xy.size(); ++i) {
      const auto [x, y] = series[gi].xy[i];
      if (!std::isfinite(x) || !std::isfinite(y)) continue;
      marker(gi, {px(x), f.py(y)});
      if (i < series[gi].names.size() && !series[gi].names[i].empty()) {
        // Beside the point, on its left when it lies in the right quarter.
        int base = 0;
        const cv::Size sz = cv::getTextSize(series[gi].names[i], kFont, 0.4, 1, &base);
        const int tx = px(x) > f.right - (f.right - f.left) / 4 ? px(x) - 10 - sz.width : px(x) + 10;
        cv::putText(img, series[gi].names[i], {tx, f.py(y) + sz.height / 2}, kFont, 0.4, black, 1, cv::LINE_AA);
      }
    }
  }
  // Legend, top or bottom right: a marker (on a stretch of line when the series are lines)
  // and the label per series, then the level's dashes.
  const std::string level_label = level ? chart.level_label : "";
  int lw = 0, base = 0;
  for (const ScatterGroup& g : series) lw = std::max(lw, cv::getTextSize(g.label, kFont, 0.45, 1, &base).width);
  if (!level_label.empty()) lw = std::max(lw, cv::getTextSize(level_label, kFont, 0.45, 1, &base).width);
  const int key = chart.lines ? 16 : 0, entries = static_cast<int>(series.size()) + (level_label.empty() ? 0 : 1);
  const int row = 20, bw = lw + 36 + key, bh = row * entries + 8;
  const int bx = f.right - bw - 8, by = chart.legend_bottom ? f.bottom - bh - 8 : f.top + 8;
  if (!series.empty() && bx > f.left && by > f.top) {
    cv::rectangle(img, {bx, by}, {bx + bw, by + bh}, cv::Scalar(255, 255, 255), cv::FILLED);
    cv::rectangle(img, {bx, by}, {bx + bw, by + bh}, cv::Scalar(160, 160, 160), 1);
    for (size_t gi = 0; gi < series.size(); ++gi) {
      const int y = by + 4 + row * static_cast<int>(gi) + row / 2;
      if (chart.lines) cv::line(img, {bx + 8, y}, {bx + 20 + key, y}, kColours[gi % 10], 2, cv::LINE_AA);
      marker(gi, {bx + 14 + key / 2, y});
      cv::putText(img, series[gi].label, {bx + 28 + key, y + 5}, kFont, 0.45, black, 1, cv::LINE_AA);
    }
    if (!level_label.empty()) {
      const int y = by + 4 + row * static_cast<int>(series.size()) + row / 2;
      dashes(bx + 8, bx + 20 + key, y);
      cv::putText(img, level_label, {bx + 28 + key, y + 5}, kFont, 0.45, black, 1, cv::LINE_AA);
    }
  }
  draw_labels(img, f, chart.title, chart.x_label, chart.y_label);
  return from_bgr(img);
}

Image8 plot_scatter(const std::vector<ScatterGroup>& groups, const std::string& title, const std::string& x_label,
                    const std::string& y_label, int width, int height) {
  XYChart chart;
  chart.title = title;
  chart.x_label = x_label;
  chart.y_label = y_label;
  return plot_xy(groups, chart, width, height);
}

Image8 image_row(const std::vector<Image8>& images, const std::vector<std::string>& captions, int gap) {
  if (images.empty()) throw Error("image_row: no images");
  int w = 0, h = 0;
  for (const Image8& im : images) {
    if (im.empty()) throw Error("image_row: an image is empty");
    w += im.width;
    h = std::max(h, im.height);
  }
  w += gap * static_cast<int>(images.size() - 1);
  bool any_caption = false;
  for (const std::string& c : captions) any_caption = any_caption || !c.empty();
  const int band = any_caption ? 22 : 0;
  cv::Mat img(h + band, w, CV_8UC3, cv::Scalar(255, 255, 255));
  int x = 0;
  for (size_t i = 0; i < images.size(); ++i) {
    to_bgr(images[i]).copyTo(img(cv::Rect(x, band, images[i].width, images[i].height)));
    if (i < captions.size() && !captions[i].empty()) {
      // Shrink the text to fit above its image.
      double scale = 0.45;
      int base = 0;
      while (scale > 0.25 && cv::getTextSize(captions[i], kFont, scale, 1, &base).width > images[i].width) scale -= 0.05;
      centred_text(img, captions[i], x + images[i].width / 2, band - 6, scale, cv::Scalar(0, 0, 0));
    }
    x += images[i].width + gap;
  }
  return from_bgr(img);
}

Image8 stack_images(const std::vector<Image8>& images, int gap) {
  if (images.empty()) throw Error("stack_images: no images");
  int w = 0, h = 0;
  for (const Image8& im : images) {
    if (im.empty()) throw Error("stack_images: an image is empty");
    w = std::max(w, im.width);
    h += im.height;
  }
  h += gap * static_cast<int>(images.size() - 1);
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  int y = 0;
  for (const Image8& im : images) {
    to_bgr(im).copyTo(img(cv::Rect(0, y, im.width, im.height)));
    y += im.height + gap;
  }
  return from_bgr(img);
}

}  // namespace nova

#pragma once
// Charts and picture sheets (RGB, white background, Tableau 10 colours). Implemented in nova_io
// (OpenCV); no OpenCV types here.
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "nova/model/scene.hpp"

namespace nova {

// About `target` tick values over [lo, hi], at a step of 1, 2 or 5 times a power of ten (a
// multiple of the step, exact 0 where it falls); the step goes to *step_out.
std::vector<double> axis_ticks(double lo, double hi, int target, double* step_out);
// A tick value with as many decimals as the step needs.
std::string axis_tick_text(double v, double step);

// Bars in groups (e.g. scenes grouped by set): group g's bars in colour g, each bar labelled
// beneath with its name and above with its value (`decimals`), the group's label under its
// bars; the y axis runs from 0 to above the largest value, with ticks. Non-finite values
// draw no bar ("n/a" above the slot).
struct BarGroup {
  std::string label;
  std::vector<std::pair<std::string, double>> bars;  // name, value
};
Image8 plot_bar_groups(const std::vector<BarGroup>& groups, const std::string& title, const std::string& y_label,
                       int decimals = 2, int width = 1000, int height = 420);

// Points coloured by group with a legend; x from 0 to above the largest x, y around the data.
// Non-finite points are left out. A point's name (when `names` has one) is written beside it.
struct ScatterGroup {
  std::string label;
  std::vector<std::pair<double, double>> xy;
  std::vector<std::string> names;  // optional, one per point
};
Image8 plot_scatter(const std::vector<ScatterGroup>& groups, const std::string& title, const std::string& x_label,
                    const std::string& y_label, int width = 1000, int height = 420);

// The x-y chart behind plot_scatter (and nova-bench tradeoff's curves): the points of each
// series in its colour (from the eleventh series on, square markers), joined in order by a
// line when `lines`; a legend at the top right (bottom right: `legend_bottom`); a dashed
// horizontal line at `level` when it is finite, with `level_label` in the legend. x runs from
// 0 to above the largest x, y around the points and the level.
struct XYChart {
  std::string title, x_label, y_label;
  bool lines = false;
  int marker = 6;  // radius in pixels
  bool legend_bottom = false;
  double level = NAN;
  std::string level_label;
};
Image8 plot_xy(const std::vector<ScatterGroup>& series, const XYChart& chart, int width = 1000, int height = 420);

// The images left to right, `gap` pixels apart, each under its caption (a band of text above
// the row; captions may be empty, or fewer than the images). Grey images are drawn as RGB;
// images keep their pixels exactly. Throws nova::Error when `images` is empty or an image is
// empty.
Image8 image_row(const std::vector<Image8>& images, const std::vector<std::string>& captions = {}, int gap = 8);
// The images top to bottom, left-aligned, `gap` pixels apart (RGB; the width of the widest).
Image8 stack_images(const std::vector<Image8>& images, int gap = 8);

}  // namespace nova

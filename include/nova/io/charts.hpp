#pragma once
// Turning rendered buffers into pictures and videos: RGB and grey quantisation, depth maps in
// colour, and MP4 output. Implemented in nova_io (OpenCV); no OpenCV types here. Images are
// RGB-interleaved Image8 as everywhere in nova (include/nova/model/scene.hpp); PNG output is
// nova::write_png (include/nova/io/image_io.hpp).
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "nova/model/scene.hpp"

namespace nova {

// [height * width * 3] values in [0, 1] -> RGB, with nova::quantize_unit (clamped, rounded
// half up, NaN -> 0): the quantisation the metrics assume.
Image8 float_rgb_to_image(const std::vector<float>& rgb, int width, int height);
// [height * width] values in [0, 1] (masks, opacity, blending weights) -> one 8-bit channel,
// with the same quantisation.
Image8 float_to_gray(const std::vector<float>& v, int width, int height);

struct DepthRange {
  float lo = 0, hi = 1;
};
// The 1st and 99th percentiles (by default) of the finite depths, linearly interpolated as
// numpy.percentile does, so a few stray samples do not wash out the map. {0, 1} when no
// value is finite. lo == hi when the depth is constant.
DepthRange robust_depth_range(const std::vector<float>& depth, double lower_percent = 1.0,
                              double upper_percent = 99.0);

// [height * width] depths -> RGB through the viridis colormap, near (lo) bright yellow, far
// (hi) dark purple. Viridis rather than turbo because its luminance rises monotonically (up
// to the 8-bit rounding of OpenCV's table), so brightness alone reads as nearness. Depths
// outside [lo, hi] are clamped; NaN and +-inf are black. lo == hi splits at lo (<= lo
// brightest, > lo darkest). Throws nova::Error when lo or hi is not finite or lo > hi.
Image8 depth_to_color(const std::vector<float>& depth, int width, int height, float lo,
                      float hi);

// An MP4 of `frames` (all the same size, 3-channel RGB or 1-channel grey) at `fps`, through
// cv::VideoWriter's FFmpeg backend with the 'mp4v' codec, else 'avc1'. Written to
// "<stem>.tmp<ext>" beside `path` (FFmpeg picks the container from the extension) and renamed
// over `path` at the end, so a failed write leaves no partial video. Throws nova::Error when
// no codec opens (naming the codecs tried; callers write the PNG frames first, so the message
// says those are still there), the folder does not exist, `path` has no extension, the
// frames are empty or differ in size, or fps is not positive.
void write_video(const std::vector<Image8>& frames, const std::string& path, double fps);
// Whether this build writes videos (OpenCV's videoio was found); without it write_video throws.
bool video_supported();

// ---- charts and picture sheets (RGB, white background, Tableau 10 colours) ----------------

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

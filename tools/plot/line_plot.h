// Line plots and bar charts as PNG files (VTK Charts, rendered off screen): the
// displacement of a point over the steps, forces over time, any y(x) columns;
// a measure per model. Used by
// `organsim plot` and the experiment scripts (tools/experiments/).
//
// VTK 9.1 as Debian builds it renders off screen through X only: without a
// display, run under a virtual one (`xvfb-run -a organsim plot …`).
#pragma once

#include <string>
#include <vector>

namespace organsim::plot {

/// One line: y over x, drawn in the legend as `name`.
struct Series {
  std::string name;
  std::vector<double> x, y;
};

/// Logarithmic axes: every value on such an axis must be positive.
struct LogAxes {
  bool x = false;
  bool y = false;
};

/// Draws the series as lines on one chart (axes scaled to fit all of them, a
/// legend when there is more than one) and writes it atomically as a
/// `width` × `height` PNG at `png_path` (io::AtomicFile: the file appears
/// whole or not at all). Throws std::invalid_argument for no series, a series
/// whose x and y differ in length or that is empty, a non-finite value (the
/// message names the series and the point), or a size outside 64–8192 pixels;
/// std::runtime_error when there is no X display (DISPLAY unset) or the file
/// cannot be written; std::invalid_argument for a value that is not positive
/// on a logarithmic axis.
void write_line_plot_png(const std::vector<Series>& series, const std::string& title, const std::string& x_label,
                         const std::string& y_label, const std::string& png_path, int width = 800, int height = 500,
                         LogAxes log = {});

/// One kind of bar, drawn in the legend as `name`: one value per category.
struct BarSeries {
  std::string name;
  std::vector<double> values;
};

/// Grouped bars: per category (named under the x axis), one bar of each
/// series side by side. Written like write_line_plot_png, with the same
/// errors (a series with another count of values than categories too).
void write_bar_chart_png(const std::vector<std::string>& categories, const std::vector<BarSeries>& series,
                         const std::string& title, const std::string& y_label, const std::string& png_path,
                         int width = 800, int height = 500);

}  // namespace organsim::plot

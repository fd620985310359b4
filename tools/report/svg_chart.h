// Line charts as inline SVG for the training report: no script, no external
// resource, so the page opens anywhere (a USB stick, no network).
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace organsim::report {

struct ChartSeries {
  std::string name, colour;  ///< colour: a CSS colour (#rrggbb)
  std::vector<double> x, y;  ///< same length; points with a NaN y are left out
};

/// A stretch of x to shade behind the lines (an event: a grasp, a force above the limit).
struct ChartSpan {
  double from = 0.0, to = 0.0;
  std::string colour;  ///< a CSS colour (#rrggbb), drawn translucent
  std::string label;   ///< named in the legend once per label, and as the span's tooltip
};

struct ChartAxes {
  std::string x_label, y_label;
  double line_at = 0.0;  ///< a dashed horizontal line at this y (with `line_label`), when the label is set
  std::string line_label;
  std::vector<ChartSpan> spans;
  /// A range of y shaded across the plot (an expert band), when `band_label` is set.
  double band_low = 0.0, band_high = 0.0;
  std::string band_label;
  bool points = false;  ///< mark each data point with a dot (few points: attempts, whole numbers on x)
};

/// Axes with their labels only; the other fields are set by name.
inline ChartAxes labelled_axes(std::string x_label, std::string y_label) {
  ChartAxes axes;
  axes.x_label = std::move(x_label);
  axes.y_label = std::move(y_label);
  return axes;
}

/// One chart (about 900 × 260 pixels) with axes, ticks and a legend. The y
/// axis fits the data, so that a small force fills the plot: a line whose y
/// is within view (the data reach at least half of it) is drawn; one far
/// above the data is stated in words instead, with the peak's fraction of it.
std::string svg_chart(const std::vector<ChartSeries>& series, const ChartAxes& axes);

}  // namespace organsim::report

// The training report's charts (report/svg_chart.h): the y axis fits the
// data, so that a 20 mN push is seen on a chart whose limit is 2 N.
#include <algorithm>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "report/svg_chart.h"

namespace organsim::report {
namespace {

/// Force axes with a 2 N limit line.
ChartAxes limit_axes() {
  ChartAxes axes = labelled_axes("time (s)", "force (N)");
  axes.line_at = 2.0;
  axes.line_label = "limit";
  return axes;
}

/// The polyline's highest point as a fraction of the plot's height above its bottom.
double highest_fraction(const std::string& svg) {
  const std::size_t rect = svg.find("<rect ");
  double top = 0, height = 0;
  std::sscanf(svg.c_str() + svg.find("y=\"", rect), "y=\"%lf\"", &top);
  std::sscanf(svg.c_str() + svg.find("height=\"", rect), "height=\"%lf\"", &height);
  const std::size_t begin = svg.find("points=\"", svg.find("<polyline")) + 8;
  std::istringstream points(svg.substr(begin, svg.find('"', begin) - begin));
  double lowest_y = 1e9;
  for (std::string point; points >> point;) lowest_y = std::min(lowest_y, std::stod(point.substr(point.find(',') + 1)));
  return (top + height - lowest_y) / height;
}

TEST(SvgChart, ASmallForceFillsItsPlotAndAFarLimitIsStatedInWords) {
  const ChartSeries push{"force sent", "#1f77b4", {0.0, 1.0, 2.0, 3.0}, {0.0, 0.02, 0.01, 0.0}};
  const std::string svg = svg_chart({push}, limit_axes());
  EXPECT_GE(highest_fraction(svg), 0.2) << "a 20 mN push against a 2 N limit";
  EXPECT_EQ(svg.find("stroke-dasharray"), std::string::npos) << "the limit is not drawn far above the data";
  EXPECT_NE(svg.find("limit 2 is above this scale: the peak is 1.0 % of it"), std::string::npos) << svg;
}

TEST(SvgChart, ALimitTheDataComeNearIsDrawn) {
  const ChartSeries push{"force sent", "#1f77b4", {0.0, 1.0, 2.0}, {0.0, 1.5, 0.0}};
  const std::string svg = svg_chart({push}, limit_axes());
  EXPECT_NE(svg.find("stroke-dasharray"), std::string::npos);
  EXPECT_EQ(svg.find("above this scale"), std::string::npos);
  EXPECT_GE(highest_fraction(svg), 0.6);
}

// Events are shaded behind the lines over their stretch of time, each kind
// named once in the legend and every span by its tooltip.
TEST(SvgChart, EventsAreShadedOverTheirTime) {
  const ChartSeries push{"force sent", "#1f77b4", {0.0, 1.0, 2.0, 3.0, 4.0}, {0.0, 0.5, 0.5, 0.5, 0.0}};
  ChartAxes axes = limit_axes();
  axes.spans = {{1.0, 2.0, "#2ca02c", "grasp"}, {2.5, 3.0, "#2ca02c", "grasp"}};
  const std::string svg = svg_chart({push}, axes);
  std::size_t shaded = 0;
  for (std::size_t at = svg.find("<title>grasp</title>"); at != std::string::npos;
       at = svg.find("<title>grasp</title>", at + 1))
    ++shaded;
  EXPECT_EQ(shaded, 2u);
  // The first span: 1 s to 2 s of a 0-4 s axis over the plot's width.
  const std::size_t span = svg.find("fill-opacity=\"0.18\"");
  ASSERT_NE(span, std::string::npos);
  const std::size_t rect = svg.rfind("<rect ", span);
  double x = 0, width = 0;
  std::sscanf(svg.c_str() + svg.find("x=\"", rect), "x=\"%lf\"", &x);
  std::sscanf(svg.c_str() + svg.find("width=\"", rect), "width=\"%lf\"", &width);
  EXPECT_NEAR(x, 70 + 660 * 0.25, 0.1);
  EXPECT_NEAR(width, 660 * 0.25, 0.1);
  EXPECT_NE(svg.find(">grasp</text>"), std::string::npos) << "named in the legend";
}

// The learning curve's charts: an expert band shaded across the plot (the
// axis reaching it), a dot per attempt.
TEST(SvgChart, AnExpertBandIsShadedAndEachAttemptDotted) {
  const ChartSeries attempts{"tool 1", "#1f77b4", {1.0, 2.0, 3.0}, {300.0, 240.0, 180.0}};
  ChartAxes axes = labelled_axes("attempt", "path length (mm)");
  axes.band_low = 100.0;
  axes.band_high = 400.0;
  axes.band_label = "expert band";
  axes.points = true;
  const std::string svg = svg_chart({attempts}, axes);
  EXPECT_NE(svg.find("<title>expert band</title>"), std::string::npos);
  std::size_t dots = 0;
  for (std::size_t at = svg.find("<circle"); at != std::string::npos; at = svg.find("<circle", at + 1)) ++dots;
  EXPECT_EQ(dots, 3u);
  // The band's top (400) is within the axis: its rectangle starts at or below the plot's top.
  const std::size_t band = svg.rfind("<rect ", svg.find("<title>expert band</title>"));
  double band_top = 0, plot_top = 0;
  std::sscanf(svg.c_str() + svg.find("y=\"", band), "y=\"%lf\"", &band_top);
  std::sscanf(svg.c_str() + svg.find("y=\"", svg.find("<rect ")), "y=\"%lf\"", &plot_top);
  EXPECT_GT(band_top, plot_top) << "the axis reaches above the band";
}

}  // namespace
}  // namespace organsim::report

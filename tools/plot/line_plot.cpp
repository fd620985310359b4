// Line plots (line_plot.h): a vtkChartXY in an off-screen vtkContextView,
// grabbed with vtkWindowToImageFilter and written with vtkPNGWriter into an
// io::AtomicFile.
#include "line_plot.h"
#include "window_png.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <vtkAxis.h>
#include <vtkChartLegend.h>
#include <vtkChartXY.h>
#include <vtkContextScene.h>
#include <vtkContextView.h>
#include <vtkDoubleArray.h>
#include <vtkNew.h>
#include <vtkPen.h>
#include <vtkPlot.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkSmartPointer.h>
#include <vtkStringArray.h>
#include <vtkTable.h>
#include <vtkTextProperty.h>

namespace organsim::plot {
namespace {

// Matplotlib's "tab10" colours: distinct, and readable on white.
constexpr std::array<std::array<unsigned char, 3>, 10> kColours{{{31, 119, 180},
                                                                 {255, 127, 14},
                                                                 {44, 160, 44},
                                                                 {214, 39, 40},
                                                                 {148, 103, 189},
                                                                 {140, 86, 75},
                                                                 {227, 119, 194},
                                                                 {127, 127, 127},
                                                                 {188, 189, 34},
                                                                 {23, 190, 207}}};

void check_size(const char* function, int width, int height) {
  if (width < 64 || width > 8192 || height < 64 || height > 8192)
    throw std::invalid_argument(std::string(function) + ": the picture must be 64 to 8192 pixels wide and high (got " +
                                std::to_string(width) + "x" + std::to_string(height) + ")");
}

void check(const std::vector<Series>& series, int width, int height) {
  if (series.empty()) throw std::invalid_argument("write_line_plot_png: no series to plot");
  check_size("write_line_plot_png", width, height);
  for (const Series& s : series) {
    if (s.x.size() != s.y.size())
      throw std::invalid_argument("write_line_plot_png: series '" + s.name + "' has " + std::to_string(s.x.size()) +
                                  " x values but " + std::to_string(s.y.size()) + " y values");
    if (s.x.empty()) throw std::invalid_argument("write_line_plot_png: series '" + s.name + "' has no points");
    for (std::size_t i = 0; i < s.x.size(); ++i)
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i]))
        throw std::invalid_argument("write_line_plot_png: series '" + s.name + "' has a non-finite value at point " +
                                    std::to_string(i + 1));
  }
}

void check_positive(const std::vector<Series>& series, LogAxes log) {
  for (const Series& s : series)
    for (std::size_t i = 0; i < s.x.size(); ++i)
      if ((log.x && s.x[i] <= 0.0) || (log.y && s.y[i] <= 0.0))
        throw std::invalid_argument("write_line_plot_png: series '" + s.name +
                                    "' has a value that is not positive at point " + std::to_string(i + 1) +
                                    ", which a logarithmic axis cannot show");
}

/// Fixes an axis whose data span nothing (a constant series) to a visible range.
void widen_if_flat(vtkAxis* axis, double low, double high) {
  if (high > low) return;
  const double pad = low == 0.0 ? 1.0 : 0.1 * std::abs(low);
  axis->SetBehavior(vtkAxis::FIXED);
  axis->SetRange(low - pad, high + pad);
}

/// An off-screen white chart with a title, axis titles and (when asked) a legend.
struct Chart {
  vtkNew<vtkContextView> view;
  vtkNew<vtkChartXY> chart;
  vtkAxis* x_axis = nullptr;
  vtkAxis* y_axis = nullptr;

  Chart(const std::string& title, const std::string& x_label, const std::string& y_label, int width, int height,
        bool legend) {
    vtkRenderWindow* window = view->GetRenderWindow();
    window->SetOffScreenRendering(1);
    window->SetSize(width, height);
    window->SetMultiSamples(0);
    view->GetRenderer()->SetBackground(1.0, 1.0, 1.0);
    view->GetScene()->AddItem(chart);
    chart->SetTitle(title);
    chart->GetTitleProperties()->SetFontSize(16);
    chart->GetTitleProperties()->SetBold(true);
    x_axis = chart->GetAxis(vtkAxis::BOTTOM);
    y_axis = chart->GetAxis(vtkAxis::LEFT);
    x_axis->SetTitle(x_label);
    y_axis->SetTitle(y_label);
    for (vtkAxis* axis : {x_axis, y_axis}) {
      axis->GetTitleProperties()->SetFontSize(14);
      axis->GetTitleProperties()->SetBold(false);
      axis->GetLabelProperties()->SetFontSize(12);
    }
    chart->SetShowLegend(legend);
    chart->GetLegend()->GetLabelProperties()->SetFontSize(12);
  }
  vtkRenderWindow* window() { return view->GetRenderWindow(); }
};

}  // namespace

void write_line_plot_png(const std::vector<Series>& series, const std::string& title, const std::string& x_label,
                         const std::string& y_label, const std::string& png_path, int width, int height, LogAxes log) {
  check(series, width, height);
  check_positive(series, log);
  require_display(png_path);
  Chart plot(title, x_label, y_label, width, height, series.size() > 1);
  vtkChartXY* chart = plot.chart;
  vtkAxis* x_axis = plot.x_axis;
  vtkAxis* y_axis = plot.y_axis;

  double x_low = std::numeric_limits<double>::infinity(), x_high = -x_low, y_low = x_low, y_high = -x_low;
  std::vector<vtkSmartPointer<vtkTable>> tables;
  for (std::size_t k = 0; k < series.size(); ++k) {
    const Series& s = series[k];
    vtkNew<vtkDoubleArray> x, y;
    x->SetName(x_label.empty() ? "x" : x_label.c_str());
    y->SetName(s.name.empty() ? "y" : s.name.c_str());
    x->SetNumberOfValues(static_cast<vtkIdType>(s.x.size()));
    y->SetNumberOfValues(static_cast<vtkIdType>(s.y.size()));
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      x->SetValue(static_cast<vtkIdType>(i), s.x[i]);
      y->SetValue(static_cast<vtkIdType>(i), s.y[i]);
      x_low = std::min(x_low, s.x[i]), x_high = std::max(x_high, s.x[i]);
      y_low = std::min(y_low, s.y[i]), y_high = std::max(y_high, s.y[i]);
    }
    auto table = vtkSmartPointer<vtkTable>::New();
    table->AddColumn(x);
    table->AddColumn(y);
    tables.push_back(table);
    vtkPlot* line = chart->AddPlot(vtkChart::LINE);
    line->SetInputData(table, 0, 1);
    const auto& colour = kColours[k % kColours.size()];
    line->SetColor(colour[0], colour[1], colour[2], 255);
    line->SetWidth(2.0);
    // Series past the palette's length are told apart by their dash pattern.
    if (k >= kColours.size()) line->GetPen()->SetLineType(vtkPen::DASH_LINE);
  }
  x_axis->SetLogScale(log.x);
  y_axis->SetLogScale(log.y);
  // Scaling curves rise to the right: their legend goes top left, over the empty corner.
  if (log.x && log.y) chart->GetLegend()->SetHorizontalAlignment(vtkChartLegend::LEFT);
  if (!log.x) widen_if_flat(x_axis, x_low, x_high);
  if (!log.y) widen_if_flat(y_axis, y_low, y_high);

  write_window_png(plot.window(), png_path);
}

void write_bar_chart_png(const std::vector<std::string>& categories, const std::vector<BarSeries>& series,
                         const std::string& title, const std::string& y_label, const std::string& png_path, int width,
                         int height) {
  if (categories.empty() || series.empty()) throw std::invalid_argument("write_bar_chart_png: nothing to draw");
  check_size("write_bar_chart_png", width, height);
  double y_high = 0.0;
  for (const BarSeries& s : series) {
    if (s.values.size() != categories.size())
      throw std::invalid_argument("write_bar_chart_png: series '" + s.name + "' has " +
                                  std::to_string(s.values.size()) + " values for " + std::to_string(categories.size()) +
                                  " categories");
    for (std::size_t i = 0; i < s.values.size(); ++i) {
      if (!std::isfinite(s.values[i]))
        throw std::invalid_argument("write_bar_chart_png: series '" + s.name + "' has a non-finite value for '" +
                                    categories[i] + "'");
      y_high = std::max(y_high, s.values[i]);
    }
  }
  require_display(png_path);
  Chart plot(title, "", y_label, width, height, series.size() > 1);

  vtkNew<vtkTable> table;
  vtkNew<vtkDoubleArray> position;
  position->SetName("category");
  position->SetNumberOfValues(static_cast<vtkIdType>(categories.size()));
  vtkNew<vtkDoubleArray> ticks;
  vtkNew<vtkStringArray> labels;
  for (std::size_t i = 0; i < categories.size(); ++i) {
    position->SetValue(static_cast<vtkIdType>(i), static_cast<double>(i + 1));
    ticks->InsertNextValue(static_cast<double>(i + 1));
    labels->InsertNextValue(categories[i]);
  }
  table->AddColumn(position);
  for (const BarSeries& s : series) {
    vtkNew<vtkDoubleArray> values;
    values->SetName(s.name.empty() ? "value" : s.name.c_str());
    values->SetNumberOfValues(static_cast<vtkIdType>(s.values.size()));
    for (std::size_t i = 0; i < s.values.size(); ++i) values->SetValue(static_cast<vtkIdType>(i), s.values[i]);
    table->AddColumn(values);
  }
  // One bar plot per series: the chart sets them side by side within each category.
  for (std::size_t k = 0; k < series.size(); ++k) {
    vtkPlot* bars = plot.chart->AddPlot(vtkChart::BAR);
    bars->SetInputData(table, 0, static_cast<vtkIdType>(k + 1));
    const auto& colour = kColours[k % kColours.size()];
    bars->SetColor(colour[0], colour[1], colour[2], 255);
  }
  plot.x_axis->SetCustomTickPositions(ticks, labels);
  plot.x_axis->SetBehavior(vtkAxis::FIXED);
  plot.x_axis->SetRange(0.4, categories.size() + 0.6);
  plot.y_axis->SetBehavior(vtkAxis::FIXED);
  plot.y_axis->SetRange(0.0, y_high > 0.0 ? 1.1 * y_high : 1.0);
  write_window_png(plot.window(), png_path);
}

}  // namespace organsim::plot

#include "svg_chart.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

namespace organsim::report {
namespace {

constexpr double kWidth = 900, kHeight = 260, kLeft = 70, kRight = 170, kTop = 15, kBottom = 45;

/// A round step for about five ticks over [low, high].
double tick_step(double low, double high) {
  const double raw = (high - low) / 5.0;
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0})
    if (raw <= m * power) return m * power;
  return 10.0 * power;
}

/// What the chart shows, in words: its text alternative for a reader who
/// cannot see it (each series' range, the line, the shaded events).
std::string text_alternative(const std::vector<ChartSeries>& series, const ChartAxes& axes, bool line_in_view) {
  std::string text = fmt::format("Chart of {} against {}", axes.y_label, axes.x_label);
  for (const ChartSeries& s : series) {
    double low = std::numeric_limits<double>::infinity(), high = -low;
    std::size_t points = 0;
    for (std::size_t k = 0; k < s.x.size() && k < s.y.size(); ++k)
      if (std::isfinite(s.y[k])) low = std::min(low, s.y[k]), high = std::max(high, s.y[k]), ++points;
    text += points == 0 ? fmt::format("; {}: no data", s.name)
                        : fmt::format("; {}: {} point{} from {:.3g} to {:.3g}", s.name, points, points == 1 ? "" : "s",
                                      low, high);
  }
  if (!axes.line_label.empty())
    text += fmt::format("; {} at {:g}{}", axes.line_label, axes.line_at, line_in_view ? "" : ", above the scale");
  if (!axes.band_label.empty())
    text += fmt::format("; {} shaded from {:.3g} to {:.3g}", axes.band_label, axes.band_low, axes.band_high);
  std::vector<std::string> named;  // each span label once, with how often it is shaded
  for (const ChartSpan& span : axes.spans) {
    if (std::find(named.begin(), named.end(), span.label) != named.end()) continue;
    named.push_back(span.label);
    const auto count = std::count_if(axes.spans.begin(), axes.spans.end(),
                                     [&](const ChartSpan& other) { return other.label == span.label; });
    text += fmt::format("; {} shaded {} time{}", span.label, count, count == 1 ? "" : "s");
  }
  text += ".";
  std::string escaped;  // for an attribute and a title
  for (const char c : text) {
    switch (c) {
      case '&': escaped += "&amp;"; break;
      case '<': escaped += "&lt;"; break;
      case '>': escaped += "&gt;"; break;
      case '"': escaped += "&quot;"; break;
      default: escaped += c;
    }
  }
  return escaped;
}

}  // namespace

std::string svg_chart(const std::vector<ChartSeries>& series, const ChartAxes& axes) {
  double x_low = std::numeric_limits<double>::infinity(), x_high = -x_low, y_low = 0.0, y_high = 0.0;
  for (const ChartSeries& s : series)
    for (std::size_t k = 0; k < s.x.size() && k < s.y.size(); ++k) {
      if (!std::isfinite(s.y[k]) || !std::isfinite(s.x[k])) continue;
      x_low = std::min(x_low, s.x[k]);
      x_high = std::max(x_high, s.x[k]);
      y_low = std::min(y_low, s.y[k]);
      y_high = std::max(y_high, s.y[k]);
    }
  const bool has_band = !axes.band_label.empty();
  if (has_band) y_high = std::max(y_high, axes.band_high), y_low = std::min(y_low, axes.band_low);
  const double peak = y_high;
  const bool has_line = !axes.line_label.empty();
  // The data fill the plot; the line joins them where they come near it.
  const bool line_in_view = has_line && (!(peak > 0.0) || peak >= 0.5 * axes.line_at);
  y_high = peak > 0.0 ? 1.1 * peak : y_high;
  if (line_in_view) y_high = std::max(y_high, axes.line_at * 1.1);
  if (!(x_high > x_low)) x_low = 0.0, x_high = std::max(x_high, 1.0);
  if (!(y_high > y_low)) y_high = y_low + 1.0;
  const double plot_w = kWidth - kLeft - kRight, plot_h = kHeight - kTop - kBottom;
  const auto px = [&](double x) { return kLeft + (x - x_low) / (x_high - x_low) * plot_w; };
  const auto py = [&](double y) { return kTop + (1.0 - (y - y_low) / (y_high - y_low)) * plot_h; };

  const std::string description = text_alternative(series, axes, line_in_view);
  std::string svg = fmt::format(
      "<svg width=\"{0}\" height=\"{1}\" viewBox=\"0 0 {0} {1}\" "
      "font-family=\"sans-serif\" font-size=\"12\" role=\"img\" aria-label=\"{2}\">\n<title>{2}</title>\n",
      kWidth, kHeight, description);
  svg += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#888\"/>\n", kLeft,
                     kTop, plot_w, plot_h);
  for (const ChartSpan& span : axes.spans) {
    const double from = px(std::clamp(span.from, x_low, x_high)), to = px(std::clamp(span.to, x_low, x_high));
    svg += fmt::format(
        "<rect x=\"{:.1f}\" y=\"{}\" width=\"{:.1f}\" height=\"{}\" fill=\"{}\" fill-opacity=\"0.18\">"
        "<title>{}</title></rect>\n",
        from, kTop, std::max(to - from, 1.0), plot_h, span.colour, span.label);
  }
  if (has_band) {
    const double top = py(std::min(axes.band_high, y_high)), bottom = py(std::max(axes.band_low, y_low));
    svg += fmt::format(
        "<rect x=\"{}\" y=\"{:.1f}\" width=\"{}\" height=\"{:.1f}\" fill=\"#2ca02c\" fill-opacity=\"0.15\">"
        "<title>{}</title></rect>\n",
        kLeft, top, plot_w, std::max(bottom - top, 1.0), axes.band_label);
  }
  // Attempts (dots) are counted: whole numbers on the x axis.
  const double xs = axes.points ? std::max(1.0, tick_step(x_low, x_high)) : tick_step(x_low, x_high),
               ys = tick_step(y_low, y_high);
  for (double x = std::ceil(x_low / xs) * xs; x <= x_high + 1e-9 * xs; x += xs)
    svg += fmt::format(
        "<line x1=\"{0:.1f}\" y1=\"{1}\" x2=\"{0:.1f}\" y2=\"{2}\" stroke=\"#eee\"/>"
        "<text x=\"{0:.1f}\" y=\"{3}\" text-anchor=\"middle\">{4:g}</text>\n",
        px(x), kTop, kTop + plot_h, kTop + plot_h + 15, x);
  for (double y = std::ceil(y_low / ys) * ys; y <= y_high + 1e-9 * ys; y += ys)
    svg += fmt::format(
        "<line x1=\"{0}\" y1=\"{1:.1f}\" x2=\"{2}\" y2=\"{1:.1f}\" stroke=\"#eee\"/>"
        "<text x=\"{3}\" y=\"{4:.1f}\" text-anchor=\"end\">{5:g}</text>\n",
        kLeft, py(y), kLeft + plot_w, kLeft - 5, py(y) + 4, y);
  svg += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", kLeft + plot_w / 2, kHeight - 8,
                     axes.x_label);
  svg += fmt::format("<text x=\"15\" y=\"{0}\" text-anchor=\"middle\" transform=\"rotate(-90 15 {0})\">{1}</text>\n",
                     kTop + plot_h / 2, axes.y_label);
  if (has_line && !line_in_view)
    svg += fmt::format(
        "<text x=\"{}\" y=\"{}\" fill=\"#c00\">{} {:g} is above this scale: the peak is {:.1f} % of it</text>\n",
        kLeft + 6, kTop + 14, axes.line_label, axes.line_at, 100.0 * peak / axes.line_at);
  if (line_in_view)
    svg += fmt::format(
        "<line x1=\"{0}\" y1=\"{1:.1f}\" x2=\"{2}\" y2=\"{1:.1f}\" stroke=\"#c00\" stroke-dasharray=\"6 4\"/>"
        "<text x=\"{3}\" y=\"{4:.1f}\" fill=\"#c00\">{5} {6:g}</text>\n",
        kLeft, py(axes.line_at), kLeft + plot_w, kLeft + 6, py(axes.line_at) - 4, axes.line_label, axes.line_at);
  std::vector<const ChartSpan*> span_legend;  // one entry per label, after the series
  for (const ChartSpan& span : axes.spans)
    if (std::none_of(span_legend.begin(), span_legend.end(),
                     [&](const ChartSpan* other) { return other->label == span.label; }))
      span_legend.push_back(&span);
  for (std::size_t k = 0; k < span_legend.size(); ++k) {
    const double legend_y = kTop + 14.0 + 18.0 * static_cast<double>(series.size() + k);
    svg += fmt::format(
        "<rect x=\"{}\" y=\"{:.1f}\" width=\"20\" height=\"10\" fill=\"{}\" fill-opacity=\"0.35\"/>"
        "<text x=\"{}\" y=\"{:.1f}\">{}</text>\n",
        kLeft + plot_w + 8, legend_y - 5, span_legend[k]->colour, kLeft + plot_w + 32, legend_y + 4,
        span_legend[k]->label);
  }
  for (std::size_t k = 0; k < series.size(); ++k) {
    const ChartSeries& s = series[k];
    // Buckets without a sample (frames are sparser than ticks) are skipped, not gaps.
    std::string points;
    for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i)
      if (std::isfinite(s.y[i])) points += fmt::format("{:.1f},{:.1f} ", px(s.x[i]), py(s.y[i]));
    if (!points.empty())
      svg +=
          fmt::format("<polyline fill=\"none\" stroke=\"{}\" stroke-width=\"2\" points=\"{}\"/>\n", s.colour, points);
    if (axes.points)
      for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i)
        if (std::isfinite(s.y[i]))
          svg += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"4\" fill=\"{}\"/>\n", px(s.x[i]), py(s.y[i]),
                             s.colour);
    const double legend_y = kTop + 14.0 + 18.0 * static_cast<double>(k);
    svg += fmt::format(
        "<line x1=\"{0}\" y1=\"{1:.1f}\" x2=\"{2}\" y2=\"{1:.1f}\" stroke=\"{3}\" stroke-width=\"3\"/>"
        "<text x=\"{4}\" y=\"{5:.1f}\">{6}</text>\n",
        kLeft + plot_w + 8, legend_y, kLeft + plot_w + 28, s.colour, kLeft + plot_w + 32, legend_y + 4, s.name);
  }
  return svg + "</svg>\n";
}

}  // namespace organsim::report

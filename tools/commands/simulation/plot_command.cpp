// `organsim plot CSV --x COLUMN --y COL[,COL…] -o OUT.png`: columns of a CSV
// file with a header line (replay's forces, springs' trace, …) as a line plot
// (tools/plot/line_plot.h; VTK off screen, so under xvfb-run without a display);
// with --log-x --log-y, a scaling curve and its fitted exponent.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "command_line/command_line.h"
#include "plot/line_plot.h"
#include "power_law/power_law.h"

namespace organsim::cli {
namespace {

struct PlotOptions {
  std::string csv_path;
  std::string x;
  std::vector<std::string> y;
  std::string out_path;
  std::string title;
  std::string x_label, y_label;
  std::vector<int> size{800, 500};
  plot::LogAxes log;
};

std::string trimmed(const std::string& text) {
  const auto first = text.find_first_not_of(" \t\r");
  if (first == std::string::npos) return {};
  return text.substr(first, text.find_last_not_of(" \t\r") - first + 1);
}

std::vector<std::string> fields_of(const std::string& line) {
  std::vector<std::string> fields;
  std::size_t start = 0;
  for (;;) {
    const std::size_t comma = line.find(',', start);
    fields.push_back(trimmed(line.substr(start, comma == std::string::npos ? std::string::npos : comma - start)));
    if (comma == std::string::npos) return fields;
    start = comma + 1;
  }
}

/// The series y_k(x) of the CSV at `path`. An empty field is a missing value:
/// that row gives no point to that series (to every series, when it is x's).
std::vector<plot::Series> read_series(const std::string& path, const std::string& x,
                                      const std::vector<std::string>& y) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot open the CSV file " + path + "; check the path");
  std::string line;
  std::size_t line_number = 0;
  // The header: the first line that is not blank.
  std::vector<std::string> header;
  while (header.empty() && std::getline(in, line)) {
    ++line_number;
    if (!trimmed(line).empty()) header = fields_of(line);
  }
  if (header.empty()) throw std::runtime_error(path + " is empty; expected a header line naming the columns");
  std::vector<std::string> wanted{x};
  wanted.insert(wanted.end(), y.begin(), y.end());
  std::vector<std::size_t> index;
  for (const std::string& name : wanted) {
    const auto found = std::find(header.begin(), header.end(), name);
    if (found == header.end()) {
      std::string names;
      for (const std::string& h : header) names += (names.empty() ? "" : ", ") + h;
      throw std::runtime_error(fmt::format("{} has no column '{}' (its columns: {})", path, name, names));
    }
    index.push_back(static_cast<std::size_t>(found - header.begin()));
  }
  std::vector<plot::Series> series;
  for (const std::string& name : y) series.push_back({name, {}, {}});
  std::size_t rows = 0;
  std::vector<double> values(wanted.size());
  std::vector<bool> present(wanted.size());
  while (std::getline(in, line)) {
    ++line_number;
    if (trimmed(line).empty()) continue;
    ++rows;
    const std::vector<std::string> fields = fields_of(line);
    if (fields.size() != header.size())
      throw std::runtime_error(fmt::format("{}:{}: expected {} comma-separated fields (as the header), got {}", path,
                                           line_number, header.size(), fields.size()));
    for (std::size_t c = 0; c < wanted.size(); ++c) {
      const std::string& text = fields[index[c]];
      present[c] = !text.empty();
      if (!present[c]) continue;
      char* end = nullptr;
      values[c] = std::strtod(text.c_str(), &end);
      if (end != text.c_str() + text.size() || !std::isfinite(values[c]))
        throw std::runtime_error(
            fmt::format("{}:{}: column '{}' is not a finite number: '{}'", path, line_number, wanted[c], text));
    }
    if (!present[0]) continue;
    for (std::size_t k = 0; k < y.size(); ++k)
      if (present[k + 1]) {
        series[k].x.push_back(values[0]);
        series[k].y.push_back(values[k + 1]);
      }
  }
  if (rows == 0) throw std::runtime_error(path + " has a header but no data rows");
  for (const plot::Series& s : series)
    if (s.x.empty())
      throw std::runtime_error(
          fmt::format("{}: column '{}' has no values (every row leaves it or '{}' empty)", path, s.name, x));
  return series;
}

bool ends_with_png(const std::string& path) {
  if (path.size() < 4) return false;
  std::string extension = path.substr(path.size() - 4);
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension == ".png";
}

int run_plot(const PlotOptions& o) {
  for (const std::string& name : o.y)
    if (name.empty()) throw CLI::ValidationError("--y", "a column name is empty");
  if (!ends_with_png(o.out_path)) throw std::runtime_error("-o " + o.out_path + ": the plot is a PNG; name it .png");
  const std::vector<plot::Series> series = read_series(o.csv_path, o.x, o.y);
  std::size_t points = 0;
  for (const plot::Series& s : series) points = std::max(points, s.x.size());
  std::string y_label = o.y_label;
  if (y_label.empty())
    for (const std::string& name : o.y) y_label += (y_label.empty() ? "" : ", ") + name;
  // On log-log axes each series' fitted power law: printed, and in its legend.
  std::vector<plot::Series> drawn = series;
  std::vector<std::string> exponents;
  if (o.log.x && o.log.y)
    for (plot::Series& s : drawn) {
      const double exponent = plot::fit_power_law(s.x, s.y, "series '" + s.name + "'").exponent;
      exponents.push_back(fmt::format("{:<8}{}: exponent {:.2f} (least squares on the logs, {} points)", "fit", s.name,
                                      exponent, s.x.size()));
      s.name += fmt::format(" (exponent {:.2f})", exponent);
    }
  plot::write_line_plot_png(drawn, o.title.empty() ? o.csv_path : o.title, o.x_label.empty() ? o.x : o.x_label, y_label,
                            o.out_path, o.size[0], o.size[1], o.log);
  std::cout << fmt::format("{:<8}{} ({} series of up to {} points from {}, {}x{} pixels)\n", "plot", o.out_path,
                           series.size(), points, o.csv_path, o.size[0], o.size[1]);
  for (const std::string& line : exponents) std::cout << line << '\n';
  return 0;
}

}  // namespace

Command add_plot_command(CLI::App& app) {
  auto o = std::make_shared<PlotOptions>();
  app.add_option("CSV", o->csv_path, "CSV file with a header line naming the columns")->required();
  app.add_option("--x", o->x, "Column for the horizontal axis")->required();
  app.add_option("--y", o->y, "Columns to plot, one line each: COL[,COL...]")->delimiter(',')->required();
  app.add_option("-o,--output", o->out_path, "The plot (.png)")->required();
  app.add_option("--title", o->title, "Title (default: the CSV file's path)");
  app.add_option("--x-label", o->x_label, "Horizontal axis title (default: the --x column)");
  app.add_option("--y-label", o->y_label, "Vertical axis title (default: the --y columns)");
  app.add_flag("--log-x", o->log.x, "Logarithmic horizontal axis (its values must be positive)");
  app.add_flag("--log-y", o->log.y,
               "Logarithmic vertical axis; with --log-x, each series' power-law exponent is fitted and printed");
  app.add_option("--size", o->size, "Picture size W,H, pixels (64 to 8192 each)")
      ->delimiter(',')
      ->expected(2)
      ->check(CLI::Range(64, 8192))
      ->capture_default_str();
  return [o] { return run_plot(*o); };
}

}  // namespace organsim::cli

#include "training_report.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <memory>
#include <sstream>
#include <utility>
#include <stdexcept>

#include <Eigen/Geometry>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <vtkBase64Utilities.h>

#include "organsim/io/atomic_file.h"
#include "surface_picture.h"
#include "svg_chart.h"

namespace organsim::report {
namespace {

namespace fs = std::filesystem;

constexpr std::size_t kBuckets = 600;  // points per curve on the page
const double kNaN = std::numeric_limits<double>::quiet_NaN();

/// A CSV file with a header, read row by row into numbers.
class CsvRows {
 public:
  /// Rows of `columns` values, or of `more_columns` where a newer writer added some (0: none).
  CsvRows(const fs::path& path, std::size_t columns, std::size_t more_columns = 0)
      : path_(path), columns_(columns), more_columns_(more_columns), in_(path) {
    if (!in_) throw std::runtime_error(fmt::format("{}: missing; was the run recorded with --report?", path.string()));
    std::string header;
    std::getline(in_, header);
  }
  bool next(std::vector<double>& row) {
    std::string line;
    while (std::getline(in_, line)) {
      ++line_number_;
      if (line.empty()) continue;
      row.clear();
      const char* p = line.c_str();
      while (true) {
        char* end = nullptr;
        row.push_back(std::strtod(p, &end));
        if (end == p)
          throw std::runtime_error(fmt::format("{}: line {}: not a number", path_.string(), line_number_ + 1));
        p = end;
        if (*p != ',') break;
        ++p;
      }
      if (row.size() != columns_ && (more_columns_ == 0 || row.size() != more_columns_))
        throw std::runtime_error(fmt::format(
            "{}: line {}: {} values, expected {}", path_.string(), line_number_ + 1, row.size(),
            more_columns_ == 0 ? std::to_string(columns_) : fmt::format("{} or {}", columns_, more_columns_)));
      return true;
    }
    return false;
  }

 private:
  fs::path path_;
  std::size_t columns_, more_columns_;
  std::ifstream in_;
  std::size_t line_number_ = 0;
};

nlohmann::json read_json(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(fmt::format("{}: missing; was the run recorded with --report?", path.string()));
  try {
    return nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(fmt::format("{}: not valid JSON ({})", path.string(), e.what()));
  }
}

/// Bucketed accumulation of a curve: the largest value or the mean per bucket.
struct Accumulator {
  std::vector<double> sum, largest;
  std::vector<std::uint32_t> count;
  explicit Accumulator(std::size_t buckets) : sum(buckets, 0.0), largest(buckets, kNaN), count(buckets, 0) {}
  void add(std::size_t bucket, double value) {
    sum[bucket] += value;
    largest[bucket] = std::isnan(largest[bucket]) ? value : std::max(largest[bucket], value);
    ++count[bucket];
  }
  Curve maxima() const { return {largest}; }
  Curve means() const {
    Curve c;
    for (std::size_t b = 0; b < sum.size(); ++b) c.values.push_back(count[b] ? sum[b] / count[b] : kNaN);
    return c;
  }
};

/// A force as people say it: "27 mN" below a newton, "1.23 N" above.
std::string force_text(double newtons) {
  return newtons < 1.0 ? fmt::format("{:.3g} mN", newtons * 1e3) : fmt::format("{:.3g} N", newtons);
}

std::string escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string number_or_dash(const nlohmann::json& value, const char* format) {
  return value.is_number() ? fmt::format(fmt::runtime(format), value.get<double>()) : "–";
}

/// The organ's surface from surface.csv and triangles.csv, coloured by peak
/// indentation, the events marked, seen from three sides: PNG data URIs (or
/// the reason a picture is missing).
struct Pictures {
  struct View {
    std::string title, description, uri;  // the caption, its text alternative, a PNG data URI
    /// Where the point pressed deepest lands in the picture (pixels from the
    /// top-left corner), or none when nothing was pressed.
    std::optional<std::array<double, 2>> deepest_pixel;
  };
  std::vector<View> views;
  std::vector<std::string> problems;
};

Pictures render_organ(const fs::path& directory, const RunMetrics& metrics) {
  SurfacePicture picture;
  std::vector<double> row;
  CsvRows surface(directory / "surface.csv", 4);
  double deepest = 0.0;
  while (surface.next(row)) {
    picture.points.push_back({row[0], row[1], row[2]});
    picture.values.push_back(row[3]);
    deepest = std::max(deepest, row[3]);
  }
  CsvRows triangles(directory / "triangles.csv", 3, 4);
  while (triangles.next(row))
    picture.triangles.push_back(
        {static_cast<std::int32_t>(row[0]), static_cast<std::int32_t>(row[1]), static_cast<std::int32_t>(row[2])});
  for (const ToolMetrics& tool : metrics.tools) {
    for (const LimitEvent& e : tool.events) picture.markers.push_back({e.where_mm[0], e.where_mm[1], e.where_mm[2]});
    for (const GraspEvent& g : tool.grasps)
      if (g.slipped) picture.markers.push_back({g.where_mm[0], g.where_mm[1], g.where_mm[2]});
  }
  picture.marker_radius = 3.0;
  picture.scale_title = "deepest indentation (mm)";
  picture.low = 0.0;
  picture.high = std::max(deepest, 1e-3);
  picture.width = 420;
  picture.height = 380;
  // LPS: anterior is −y, superior +z, the patient's right −x.
  struct Side {
    std::string title;
    std::array<double, 3> direction, up;
  };
  std::vector<Side> sides = {{"seen from the front (anterior)", {0, 1, 0}, {0, 0, 1}},
                             {"seen from the right", {1, 0, 0}, {0, 0, 1}},
                             {"seen from above (superior)", {0, 0, -1}, {0, -1, 0}}};
  // And face-on where the organ was pressed deepest: the eye outside the
  // surface on its normal there, whichever side that is.
  const std::size_t deepest_point =
      static_cast<std::size_t>(std::max_element(picture.values.begin(), picture.values.end()) - picture.values.begin());
  if (deepest > 0.0) {
    const std::size_t at = deepest_point;
    std::array<double, 3> normal{0, 0, 0};  // area-weighted, outward
    for (const auto& t : picture.triangles) {
      if (t[0] != static_cast<std::int32_t>(at) && t[1] != static_cast<std::int32_t>(at) &&
          t[2] != static_cast<std::int32_t>(at))
        continue;
      const auto& a = picture.points[t[0]];
      const auto& b = picture.points[t[1]];
      const auto& c = picture.points[t[2]];
      const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
      normal[0] += u[1] * v[2] - u[2] * v[1];
      normal[1] += u[2] * v[0] - u[0] * v[2];
      normal[2] += u[0] * v[1] - u[1] * v[0];
    }
    const double length = std::sqrt(normal[0] * normal[0] + normal[1] * normal[1] + normal[2] * normal[2]);
    if (length > 0.0) {
      const std::array<double, 3> direction{-normal[0] / length, -normal[1] / length, -normal[2] / length};
      const std::array<double, 3> up =
          std::abs(direction[2]) > 0.9 ? std::array<double, 3>{0, -1, 0} : std::array<double, 3>{0, 0, 1};
      sides.push_back({"seen face-on where it was pressed deepest", direction, up});
    }
  }
  Pictures pictures;
  for (const Side& side : sides) {
    picture.title = side.title;
    picture.view_direction = side.direction;
    picture.view_up = side.up;
    try {
      const std::vector<unsigned char> png = draw_surface_png(picture);
      std::string encoded(png.size() * 4 / 3 + 8, '\0');
      const unsigned long length =
          vtkBase64Utilities::Encode(png.data(), png.size(), reinterpret_cast<unsigned char*>(encoded.data()));
      encoded.resize(length);
      const std::string description = fmt::format(
          "The organ {}, coloured by the deepest indentation each point reached, from 0 mm (blue) to {:.2g} mm "
          "(red){}",
          side.title, picture.high,
          picture.markers.empty() ? std::string()
                                  : fmt::format("; {} event{} marked with black discs", picture.markers.size(),
                                                picture.markers.size() == 1 ? "" : "s"));
      std::optional<std::array<double, 2>> deepest_pixel;
      if (deepest > 0.0) deepest_pixel = picture_pixel(picture, picture.points[deepest_point]);
      pictures.views.push_back({side.title, description, "data:image/png;base64," + encoded, deepest_pixel});
    } catch (const std::exception& e) {
      pictures.problems.push_back(fmt::format("{}: not drawn: {}", side.title, e.what()));
    }
  }
  return pictures;
}

std::vector<double> bucket_times(const RunMetrics& m) {
  std::vector<double> t;
  for (std::size_t b = 0; b < kBuckets; ++b) t.push_back((static_cast<double>(b) + 0.5) * m.bucket_s);
  return t;
}

std::string tool_table(const RunMetrics& m, const RunMetrics* reference) {
  std::string html = "<table><tr><th>tool</th><th>metric</th><th>this run</th>";
  if (reference) html += "<th>reference</th><th>difference</th>";
  html += "</tr>\n";
  for (std::size_t i = 0; i < m.tools.size(); ++i) {
    const ToolMetrics& t = m.tools[i];
    const ToolMetrics* r = reference && i < reference->tools.size() ? &reference->tools[i] : nullptr;
    const struct {
      const char* name;
      double ours, theirs;
      const char* unit;
      bool count = false;
    } rows[] = {
        {"peak force sent", t.peak_force_n, r ? r->peak_force_n : 0, "N"},
        {"mean force in contact", t.mean_force_in_contact_n, r ? r->mean_force_in_contact_n : 0, "N"},
        {"peak model force (before the clamp)", t.peak_model_force_n, r ? r->peak_model_force_n : 0, "N"},
        {"time in contact", t.time_in_contact_s, r ? r->time_in_contact_s : 0, "s"},
        {"time above the limit", t.time_above_limit_s, r ? r->time_above_limit_s : 0, "s"},
        {"events above the limit", static_cast<double>(t.events.size()), r ? static_cast<double>(r->events.size()) : 0,
         "", true},
        {"grasps", static_cast<double>(t.grasps.size()), r ? static_cast<double>(r->grasps.size()) : 0, "", true},
        {"deepest indentation", t.peak_depth_mm, r ? r->peak_depth_mm : 0, "mm"},
        {"path length of the tip", t.path_length_mm, r ? r->path_length_mm : 0, "mm"},
        {"mean tip speed", t.mean_speed_mm_s, r ? r->mean_speed_mm_s : 0, "mm/s"},
        {"economy of motion (1: straight from place to place)", t.economy_of_motion, r ? r->economy_of_motion : 0, ""},
        {"mean squared jerk of the tip (smoothness; lower is smoother)", t.mean_squared_jerk,
         r ? r->mean_squared_jerk : 0, "mm²/s⁶"},
        {"idle time (tip slower than 5 mm/s)", t.idle_time_s, r ? r->idle_time_s : 0, "s"}};
    for (const auto& row : rows) {
      // Counts whole, large values (the jerk's) in four significant digits, the rest to 1/1000.
      const auto text = [&](double value, bool sign) {
        if (row.count) return fmt::format(sign ? "{:+.0f}" : "{:.0f}", value);
        if (std::abs(value) >= 1e5) return fmt::format(sign ? "{:+.4g}" : "{:.4g}", value);
        return fmt::format(sign ? "{:+.3f}" : "{:.3f}", value);
      };
      html +=
          fmt::format("<tr><td>{}</td><td>{}</td><td>{} {}</td>", t.tool, row.name, text(row.ours, false), row.unit);
      if (reference)
        html += r ? fmt::format("<td>{} {}</td><td>{} {}</td>", text(row.theirs, false), row.unit,
                                text(row.ours - row.theirs, true), row.unit)
                  : "<td>–</td><td>–</td>";
      html += "</tr>\n";
    }
  }
  return html + "</table>\n";
}

/// The whole session beside the reference's: duration, the largest volume
/// change and the loops' counts (a count either run did not measure: –).
std::string session_table(const RunMetrics& m, const RunMetrics& reference) {
  std::string html = "<table><tr><th>session</th><th>this run</th><th>reference</th><th>difference</th></tr>\n";
  html += fmt::format("<tr><td>duration</td><td>{:.2f} s</td><td>{:.2f} s</td><td>{:+.2f} s</td></tr>\n", m.duration_s,
                      reference.duration_s, m.duration_s - reference.duration_s);
  html += fmt::format("<tr><td>largest volume change</td><td>{:.3f} %</td><td>{:.3f} %</td><td>{:+.3f} %</td></tr>\n",
                      m.largest_volume_change_percent, reference.largest_volume_change_percent,
                      m.largest_volume_change_percent - reference.largest_volume_change_percent);
  const nlohmann::json ours = m.run.value("loop_health", nlohmann::json::object()),
                       theirs = reference.run.value("loop_health", nlohmann::json::object());
  for (const auto& [key, name] :
       {std::pair<const char*, const char*>{"force_deadline_misses", "force-loop deadline misses"},
        {"frames_dropped", "deformation frames dropped"},
        {"pose_faults", "device faults (lost poses)"},
        {"refused_contacts", "contacts refused"}}) {
    const nlohmann::json a = ours.value(key, nlohmann::json()), b = theirs.value(key, nlohmann::json());
    const auto text = [](const nlohmann::json& count) { return count.is_number() ? count.dump() : std::string("–"); };
    const std::string difference =
        a.is_number() && b.is_number() ? fmt::format("{:+d}", a.get<std::int64_t>() - b.get<std::int64_t>()) : "–";
    html += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>\n", name, text(a), text(b), difference);
  }
  return html + "</table>\n";
}

std::vector<Measure> skill_measures_of(const RunMetrics& m) {
  std::vector<Measure> measures = {
      {"task_time_s", "task time", "s", 0, m.duration_s},
      {"damaged_area_mm2", "surface strained beyond the strain limit", "mm²", 0, m.damaged_area_mm2},
      {"largest_surface_strain", "largest surface strain", "", 0, m.largest_strain}};
  for (const ToolMetrics& t : m.tools) {
    const double slips = static_cast<double>(
        std::count_if(t.grasps.begin(), t.grasps.end(), [](const GraspEvent& g) { return g.slipped; }));
    for (Measure measure : std::vector<Measure>{
             {"time_in_contact_s", "time in contact", "s", 0, t.time_in_contact_s},
             {"path_length_mm", "path length of the tip", "mm", 0, t.path_length_mm},
             {"economy_of_motion", "economy of motion", "", 0, t.economy_of_motion},
             {"mean_squared_jerk_mm2_s6", "mean squared jerk of the tip", "mm²/s⁶", 0, t.mean_squared_jerk},
             {"idle_time_s", "idle time", "s", 0, t.idle_time_s},
             {"peak_model_force_n", "peak model force", "N", 0, t.peak_model_force_n},
             {"time_above_limit_s", "time above the force limit", "s", 0, t.time_above_limit_s},
             {"grasp_slips", "grasp slips", "", 0, slips}}) {
      measure.tool = t.tool;
      measures.push_back(measure);
    }
  }
  return measures;
}

std::string measure_value_text(const Measure& measure) {
  return fmt::format("{:.4g}{}{}", measure.value, measure.unit.empty() ? "" : " ", measure.unit);
}

std::string measure_name(const Measure& measure) {
  return measure.tool > 0 ? fmt::format("tool {}: {}", measure.tool, measure.label) : measure.label;
}

/// Each measure with a band, judged: how many lie within their band.
struct Proficiency {
  struct Check {
    Measure measure;
    Band band;
    bool within = false;
  };
  std::vector<Check> checks;
  std::size_t within = 0;
};

Proficiency judge(const RunMetrics& m, const std::map<std::string, Band>& bands) {
  Proficiency p;
  for (const Measure& measure : skill_measures_of(m)) {
    const auto band = bands.find(measure.key);
    if (band == bands.end()) continue;
    const bool within = measure.value >= band->second.low && measure.value <= band->second.high;
    p.checks.push_back({measure, band->second, within});
    p.within += within;
  }
  return p;
}

/// The answer first, in plain words: what was done and for how long, the
/// strongest force against the limit, the damage events, and how the run
/// compares with a reference run when there is one.
std::string summary(const RunMetrics& m, const RunMetrics* reference, const Proficiency* proficiency) {
  std::vector<std::string> lines;
  std::size_t slips = 0, events = 0;
  double contact = 0.0, path = 0.0;
  const ToolMetrics* strongest = nullptr;
  for (const ToolMetrics& tool : m.tools) {
    contact += tool.time_in_contact_s;
    path += tool.path_length_mm;
    events += tool.events.size();
    for (const GraspEvent& g : tool.grasps) slips += g.slipped;
    if (!strongest || tool.peak_model_force_n > strongest->peak_model_force_n) strongest = &tool;
  }
  std::string hands;
  for (const ToolMetrics& tool : m.tools) {
    hands += fmt::format("{}tool {} ", hands.empty() ? "" : ", ", tool.tool);
    hands += tool.time_in_contact_s > 0.0 ? fmt::format("in contact {:.1f} s", tool.time_in_contact_s)
                                          : std::string("never touched the organ");
    if (!tool.grasps.empty())
      hands += fmt::format(" ({} grasp{})", tool.grasps.size(), tool.grasps.size() == 1 ? "" : "s");
  }
  lines.push_back(fmt::format("{:.1f} s with {} tool{}: {}; the tips moved {:.0f} mm.", m.duration_s, m.tools.size(),
                              m.tools.size() == 1 ? "" : "s", hands, path));
  if (strongest && strongest->peak_model_force_n > 0.0)
    lines.push_back(fmt::format("The strongest force: tool {}, {} ({:.0f} % of the {:g} N limit).", strongest->tool,
                                force_text(strongest->peak_model_force_n),
                                100.0 * strongest->peak_model_force_n / m.force_limit_n, m.force_limit_n));
  if (events == 0 && slips == 0 && m.damaged_area_mm2 == 0.0) {
    lines.push_back(
        fmt::format("No damage: no force went above the limit, no grasp slipped, and no part of the "
                    "surface was strained beyond {:g} % (the largest strain: {:.1f} %).",
                    100 * m.strain_limit, 100 * m.largest_strain));
  } else {
    std::string damage;
    for (const ToolMetrics& tool : m.tools)
      for (const LimitEvent& e : tool.events)
        damage +=
            fmt::format("{}tool {} above the limit at {:.1f} s for {:.2f} s (peak {})", damage.empty() ? "" : "; ",
                        tool.tool, e.start_s, e.duration_s, force_text(e.peak_force_n));
    for (const ToolMetrics& tool : m.tools)
      for (const GraspEvent& g : tool.grasps)
        if (g.slipped)
          damage += fmt::format("{}tool {}'s grasp slipped at {:.1f} s (pulled {})", damage.empty() ? "" : "; ",
                                tool.tool, g.start_s + g.duration_s, force_text(g.peak_force_n));
    if (m.damaged_area_mm2 > 0.0)
      damage +=
          fmt::format("{}{:.0f} mm² of the surface strained beyond {:g} % (the largest strain: {:.0f} %)",
                      damage.empty() ? "" : "; ", m.damaged_area_mm2, 100 * m.strain_limit, 100 * m.largest_strain);
    lines.push_back("Damage: " + damage + ". The events are marked on the organ's pictures below.");
  }
  if (reference) {
    double ref_peak = 0.0, ref_contact = 0.0, ref_path = 0.0, peak = strongest ? strongest->peak_model_force_n : 0.0;
    for (const ToolMetrics& tool : reference->tools) {
      ref_peak = std::max(ref_peak, tool.peak_model_force_n);
      ref_contact += tool.time_in_contact_s;
      ref_path += tool.path_length_mm;
    }
    const auto ratio = [](double a, double b) {
      return b > 0.0 ? fmt::format("{:.2g} times", a / b) : std::string("—");
    };
    lines.push_back(
        fmt::format("Against the reference run: {} its time ({:.1f} s), {} its strongest push, {} its "
                    "time in contact and {} its path.",
                    ratio(m.duration_s, reference->duration_s), reference->duration_s, ratio(peak, ref_peak),
                    ratio(contact, ref_contact), ratio(path, ref_path)));
  }
  if (proficiency && !proficiency->checks.empty()) {
    std::string outside;
    for (const Proficiency::Check& c : proficiency->checks)
      if (!c.within)
        outside += fmt::format("{}{} {} ({} the band {:.4g}–{:.4g})", outside.empty() ? "" : "; ",
                               measure_name(c.measure), measure_value_text(c.measure),
                               c.measure.value > c.band.high ? "above" : "below", c.band.low, c.band.high);
    lines.push_back(fmt::format("Against the expert band: {} of {} measures within it ({:.0f} %){}.",
                                proficiency->within, proficiency->checks.size(),
                                100.0 * static_cast<double>(proficiency->within) / proficiency->checks.size(),
                                outside.empty() ? "" : "; outside it: " + outside));
  }
  std::string html = "<section class=\"summary\"><h2>Summary</h2>\n<ul>\n";
  for (const std::string& line : lines) html += "<li>" + escape(line) + "</li>\n";
  return html + "</ul></section>\n";
}

std::string page(const RunMetrics& m, const RunMetrics* reference, const Proficiency* proficiency,
                 const Pictures& pictures) {
  const nlohmann::json& run = m.run;
  std::string html;
  html +=
      "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n"
      "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; style-src 'unsafe-inline'; "
      "img-src data:\">\n<title>organsim training report</title>\n<style>\n"
      "body{font-family:sans-serif;margin:1.5em;max-width:1100px;color:#222}"
      "table{border-collapse:collapse;margin:0.5em 0}td,th{border:1px solid #bbb;padding:3px 8px;text-align:left}"
      "th{background:#eee}.warn{color:#a00;font-weight:bold}.ok{color:#060}"
      "figure{display:inline-block;margin:0.3em}svg{background:#fff}"
      ".summary{background:#f3f7f3;border:1px solid #8a8;padding:0.2em 1em;font-size:1.1em}"
      "@media print{body{margin:0;max-width:none}figure,svg,table,.summary{break-inside:avoid}}\n"
      "</style></head><body>\n";
  html += "<h1>Training report</h1>\n";
  html += summary(m, reference, proficiency);
  if (proficiency && !proficiency->checks.empty()) {
    html +=
        "<h2>Against the expert band</h2>\n<table><tr><th>measure</th><th>this run</th><th>expert band</th>"
        "<th></th></tr>\n";
    for (const Proficiency::Check& c : proficiency->checks)
      html += fmt::format("<tr><td>{}</td><td>{}</td><td>{:.4g} – {:.4g}</td><td class=\"{}\">{}</td></tr>\n",
                          escape(measure_name(c.measure)), escape(measure_value_text(c.measure)), c.band.low,
                          c.band.high, c.within ? "ok" : "warn",
                          c.within ? "within" : (c.measure.value > c.band.high ? "above" : "below"));
    html += "</table>\n";
  }
  html += "<h2>Per tool</h2>\n";
  if (reference)
    html += fmt::format("<p>Compared with a reference run of the {} model ({:.2f} s, recorded {}).</p>\n",
                        escape(reference->run.value("deformation_model", "")), reference->duration_s,
                        escape(reference->run.value("date", "")));
  if (reference) html += session_table(m, *reference);
  html += tool_table(m, reference);

  const std::vector<double> t = bucket_times(m);
  if (m.tools.size() > 1) {
    // Both hands on one timeline: each tool's force, its contacts shaded in its
    // colour, every tool's grasps and stretches above the limit.
    static const char* const kToolColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd",
                                               "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22"};
    std::vector<ChartSeries> hands;
    ChartAxes axes = labelled_axes("time (s)", "force sent (N)");
    axes.line_at = m.force_limit_n;
    axes.line_label = "limit";
    for (std::size_t i = 0; i < m.tools.size(); ++i) {
      const ToolMetrics& tool = m.tools[i];
      const char* colour = kToolColours[i % std::size(kToolColours)];
      hands.push_back({fmt::format("tool {}", tool.tool), colour, t, tool.force.values});
      for (const auto& [from, to] : tool.contacts)
        axes.spans.push_back({from, to, colour, fmt::format("tool {} in contact", tool.tool)});
      for (const GraspEvent& g : tool.grasps)
        axes.spans.push_back({g.start_s, g.start_s + g.duration_s, g.slipped ? "#d62728" : "#2ca02c",
                              g.slipped ? "grasp that slipped" : "grasp"});
      for (const LimitEvent& e : tool.events)
        axes.spans.push_back({e.start_s, e.start_s + e.duration_s, "#ff0000", "above the limit"});
    }
    html += "<h3>All tools</h3>\n" + svg_chart(hands, axes);
  }
  for (std::size_t i = 0; i < m.tools.size(); ++i) {
    const ToolMetrics& tool = m.tools[i];
    html += fmt::format("<h3>Tool {}</h3>\n", tool.tool);
    std::vector<ChartSeries> force{{"force sent", "#1f77b4", t, tool.force.values},
                                   {"model force", "#ff7f0e", t, tool.model_force.values}};
    if (reference && i < reference->tools.size())
      force.push_back({"reference: force sent", "#2ca02c", bucket_times(*reference), reference->tools[i].force.values});
    // The contacts, the grasps and the stretches above the limit, shaded on the force chart.
    ChartAxes force_axes = labelled_axes("time (s)", "force (N)");
    force_axes.line_at = m.force_limit_n;
    force_axes.line_label = "limit";
    for (const auto& [from, to] : tool.contacts) force_axes.spans.push_back({from, to, "#7f7f7f", "in contact"});
    for (const GraspEvent& g : tool.grasps)
      force_axes.spans.push_back({g.start_s, g.start_s + g.duration_s, g.slipped ? "#d62728" : "#2ca02c",
                                  g.slipped ? "grasp that slipped" : "grasp"});
    for (const LimitEvent& e : tool.events)
      force_axes.spans.push_back({e.start_s, e.start_s + e.duration_s, "#ff0000", "above the limit"});
    html += svg_chart(force, force_axes);
    html +=
        svg_chart({{"indentation depth", "#9467bd", t, tool.depth.values}}, labelled_axes("time (s)", "depth (mm)"));
    html += svg_chart({{"tip speed", "#d62728", t, tool.speed.values}}, labelled_axes("time (s)", "speed (mm/s)"));
    if (tool.events.empty()) {
      html += "<p>No force above the limit.</p>\n";
    } else {
      html +=
          "<table><tr><th>event</th><th>start (s)</th><th>duration (s)</th><th>peak model force (N)</th>"
          "<th>where (LPS, mm)</th></tr>\n";
      for (std::size_t e = 0; e < tool.events.size(); ++e) {
        const LimitEvent& ev = tool.events[e];
        html += fmt::format(
            "<tr><td>{}</td><td>{:.3f}</td><td>{:.3f}</td><td>{:.3f}</td><td>{:.1f}, {:.1f}, {:.1f}</td></tr>\n", e + 1,
            ev.start_s, ev.duration_s, ev.peak_force_n, ev.where_mm[0], ev.where_mm[1], ev.where_mm[2]);
      }
      html += "</table>\n";
    }
    if (!tool.grasps.empty()) {
      html +=
          "<table><tr><th>grasp</th><th>start (s)</th><th>held (s)</th><th>peak model force (N)</th>"
          "<th>where the jaws closed (LPS, mm)</th><th>ended</th></tr>\n";
      for (std::size_t g = 0; g < tool.grasps.size(); ++g) {
        const GraspEvent& grasp = tool.grasps[g];
        html += fmt::format(
            "<tr><td>{}</td><td>{:.3f}</td><td>{:.3f}</td><td>{:.3f}</td><td>{:.1f}, {:.1f}, "
            "{:.1f}</td><td>{}</td></tr>\n",
            g + 1, grasp.start_s, grasp.duration_s, grasp.peak_force_n, grasp.where_mm[0], grasp.where_mm[1],
            grasp.where_mm[2], grasp.slipped ? "the tissue slipped out of the jaws" : "the jaws let go");
      }
      html += "</table>\n";
    }
  }

  html +=
      "<h2>The organ</h2>\n<p>The surface coloured by the deepest indentation each point reached; black discs "
      "mark where a force went above the limit or a grasp slipped.</p>\n";
  for (const Pictures::View& view : pictures.views)
    html += fmt::format("<figure><img alt=\"{}\" src=\"{}\"><figcaption>{}</figcaption></figure>\n",
                        escape(view.description), view.uri, escape(view.title));
  for (const std::string& problem : pictures.problems) html += "<p class=\"warn\">" + escape(problem) + "</p>\n";
  html += svg_chart({{"volume change", "#17becf", t, m.volume_change_percent.values}},
                    labelled_axes("time (s)", "volume change (%)"));
  html += "<h2>Engineering detail</h2>\n<p>What the run was, and whether the simulation kept up.</p>\n<table>\n";
  const auto info = [&](const std::string& key, const std::string& value) {
    html += fmt::format("<tr><th>{}</th><td>{}</td></tr>\n", escape(key), escape(value));
  };
  info("deformation model", run.value("deformation_model", ""));
  info("model file SHA-256", run.value("model_sha256", ""));
  info("session file SHA-256", run.value("session_sha256", ""));
  info("recorded", run.value("date", ""));
  info("duration", fmt::format("{:.2f} s", m.duration_s));
  info("force limit", fmt::format("{:.2f} N (judged on the model's force, before the device's clamp of {:.2f} N)",
                                  m.force_limit_n, run.value("device_max_force_n", 0.0)));
  html += "</table>\n";

  html += "<h2>Loop health</h2>\n<table>\n";
  const nlohmann::json health = run.value("loop_health", nlohmann::json::object());
  std::uint64_t lost_records = 0;
  for (const auto& d : run.value("tick_records_dropped", nlohmann::json::array()))
    lost_records += d.get<std::uint64_t>();
  // A count the command did not measure (a loop it does not own: the HD
  // servo's deadlines, a replay stepped in session time) is said to be so,
  // never shown as a healthy zero.
  const auto health_row = [&](const std::string& key, const nlohmann::json& count, const std::string& what) {
    if (!count.is_number()) {
      html += fmt::format("<tr><th>{}</th><td>not measured by this command</td></tr>\n", escape(key));
      return;
    }
    const auto value = count.get<std::uint64_t>();
    html += fmt::format("<tr><th>{}</th><td class=\"{}\">{}{}</td></tr>\n", escape(key), value ? "warn" : "ok", value,
                        value ? " — " + what : "");
  };
  const auto counted = [&](const char* key) { return health.value(key, nlohmann::json()); };
  html += fmt::format("<tr><th>force loop</th><td>{} ticks; period p50 {} ms, p99 {} ms, max {} ms</td></tr>\n",
                      health.value("force_ticks", 0),
                      number_or_dash(health.value("period_p50_ms", nlohmann::json()), "{:.3f}"),
                      number_or_dash(health.value("period_p99_ms", nlohmann::json()), "{:.3f}"),
                      number_or_dash(health.value("period_max_ms", nlohmann::json()), "{:.3f}"));
  health_row("force-loop deadline misses (> 2 ms)", counted("force_deadline_misses"), "the hand felt late forces");
  const nlohmann::json floor = health.value("machine_floor", nlohmann::json());
  if (floor.is_object())
    html += fmt::format(
        "<tr><th>the machine's own floor</th><td>{} stalls over 2 ms and {} wake-ups later than 2 ms "
        "in a {:.1f} s probe after the session{} (a spinning real-time thread, as "
        "build/tests/cpu_stalls measures): misses up to about as many are the machine's, not the "
        "simulation's</td></tr>\n",
        floor.value("stalls_over_2ms", 0), floor.value("late_wakes_over_2ms", 0), floor.value("probe_s", 0.0),
        floor.value("realtime_priority", false) ? "" : " (no real-time priority)");
  health_row("deformation frames dropped", counted("frames_dropped"), "the organ's picture lagged the tools");
  health_row("device faults (lost poses)", counted("pose_faults"), "a tool's device stopped giving its pose");
  health_row("contacts refused", counted("refused_contacts"),
             "a tool touched where no contact can be built (the clamp)");
  health_row("force records lost", lost_records, "the recorder fell behind; the metrics miss those ticks");
  html += fmt::format("<tr><th>the machine</th><td>{}</td></tr>\n</table>\n", escape(run.value("machine", "")));

  html += "</body></html>\n";
  return html;
}

}  // namespace

RunMetrics compute_metrics(const std::string& directory, double force_limit_n, double strain_limit) {
  if (!(force_limit_n > 0.0) || !std::isfinite(force_limit_n))
    throw std::runtime_error("the force limit must be a positive number of newtons");
  if (!(strain_limit > 0.0) || !std::isfinite(strain_limit))
    throw std::runtime_error("the strain limit must be a positive number");
  const fs::path dir(directory);
  RunMetrics m;
  m.run = read_json(dir / "run.json");
  m.force_limit_n = force_limit_n;
  m.duration_s = m.run.value("duration_s", 0.0);
  const std::size_t tools = m.run.value("tools", std::size_t{0});
  if (tools == 0 || !(m.duration_s >= 0.0))
    throw std::runtime_error(fmt::format("{}: no tools or no duration", (dir / "run.json").string()));
  m.bucket_s = std::max(m.duration_s, 1e-3) / kBuckets;
  const auto bucket_of = [&](double t) {
    return std::min(kBuckets - 1, static_cast<std::size_t>(std::max(t, 0.0) / m.bucket_s));
  };

  struct State {
    double previous_t = -1.0, force_sum = 0.0;
    std::uint64_t contact_ticks = 0;
    bool above = false, tip_valid = false, grasped = false, contact = false;
    Eigen::Vector3d tip = Eigen::Vector3d::Zero();
    // The motion measures: the tip every kMotionSample s (the last four, while valid).
    std::int64_t sample = -1;  // the last sample's index on the kMotionSample grid
    std::vector<Eigen::Vector3d> samples;
    double jerk_squares = 0.0;
    std::uint64_t jerks = 0;
    // Economy of motion: the places in order (start, contact onsets), and the last valid tip.
    bool started = false;
    Eigen::Vector3d place = Eigen::Vector3d::Zero(), last = Eigen::Vector3d::Zero();
    double shortest = 0.0;
  };
  std::vector<State> state(tools);
  m.tools.resize(tools);
  std::vector<Accumulator> force(tools, Accumulator(kBuckets)), model_force(tools, Accumulator(kBuckets)),
      depth(tools, Accumulator(kBuckets)), path(tools, Accumulator(kBuckets)), elapsed(tools, Accumulator(kBuckets));
  std::vector<double> row;
  // Runs recorded before grasping have no jaw columns.
  CsvRows ticks(dir / "ticks.csv", 12, 15);
  while (ticks.next(row)) {
    const double t = row[0];
    const auto i = static_cast<std::size_t>(row[1]) - 1;
    if (i >= tools)
      throw std::runtime_error(
          fmt::format("{}: tool {} beyond the run's {}", (dir / "ticks.csv").string(), i + 1, tools));
    ToolMetrics& tool = m.tools[i];
    State& s = state[i];
    tool.tool = static_cast<int>(i + 1);
    const double dt = s.previous_t < 0.0 ? 0.0 : t - s.previous_t;
    s.previous_t = t;
    const double sent = Eigen::Vector3d(row[2], row[3], row[4]).norm(), modelled = row[5];
    const bool contact = row[6] != 0.0, valid = row[11] != 0.0;
    const Eigen::Vector3d tip(row[7], row[8], row[9]);
    const std::size_t b = bucket_of(t);
    ++tool.ticks;
    tool.peak_force_n = std::max(tool.peak_force_n, sent);
    tool.peak_model_force_n = std::max(tool.peak_model_force_n, modelled);
    force[i].add(b, sent);
    model_force[i].add(b, modelled);
    depth[i].add(b, row[10]);
    tool.peak_depth_mm = std::max(tool.peak_depth_mm, row[10]);
    if (contact && !s.contact) tool.contacts.emplace_back(t, t);
    if (contact) tool.contacts.back().second = t;
    if (contact) {
      tool.time_in_contact_s += dt;
      s.force_sum += sent;
      ++s.contact_ticks;
    }
    if (!valid) ++tool.invalid_pose_ticks;
    const double step = valid && s.tip_valid ? (tip - s.tip).norm() : 0.0;
    tool.path_length_mm += step;
    path[i].add(b, step);
    elapsed[i].add(b, dt);
    if (valid) {
      // The tip on the kMotionSample grid: the first tick at or after each grid time.
      const auto index = static_cast<std::int64_t>(std::floor(t / kMotionSample + 1e-6));
      if (index != s.sample) {
        if (index != s.sample + 1) s.samples.clear();  // a gap in the valid poses: start again
        s.sample = index;
        s.samples.push_back(tip);
        if (s.samples.size() > 4) s.samples.erase(s.samples.begin());
        const std::size_t n = s.samples.size();
        if (n >= 2 && (s.samples[n - 1] - s.samples[n - 2]).norm() < kIdleSpeed * kMotionSample)
          tool.idle_time_s += kMotionSample;
        if (n == 4) {
          const Eigen::Vector3d jerk = (s.samples[3] - 3.0 * s.samples[2] + 3.0 * s.samples[1] - s.samples[0]) /
                                       (kMotionSample * kMotionSample * kMotionSample);
          s.jerk_squares += jerk.squaredNorm();
          ++s.jerks;
        }
      }
      if (!s.started) {
        s.started = true;
        s.place = tip;
      }
      if (contact && !s.contact) {
        s.shortest += (tip - s.place).norm();
        s.place = tip;
      }
      s.last = tip;
    } else {
      s.samples.clear();
      s.sample = -1;
    }
    s.contact = contact;
    s.tip = tip;
    s.tip_valid = valid;
    if (modelled > force_limit_n) {
      tool.time_above_limit_s += dt;
      if (!s.above) tool.events.push_back({t, 0.0, 0.0, tip});
      LimitEvent& e = tool.events.back();
      e.duration_s = t - e.start_s + (dt > 0.0 ? dt : 0.0);
      if (modelled > e.peak_force_n) {
        e.peak_force_n = modelled;
        e.where_mm = tip;
      }
    }
    s.above = modelled > force_limit_n;
    const bool grasped = row.size() == 15 && row[13] != 0.0, slipped = row.size() == 15 && row[14] != 0.0;
    if (grasped && !s.grasped) tool.grasps.push_back({t, 0.0, 0.0, tip, false});
    if ((grasped || slipped) && !tool.grasps.empty()) {
      GraspEvent& g = tool.grasps.back();
      g.duration_s = t - g.start_s;
      g.peak_force_n = std::max(g.peak_force_n, modelled);
      g.slipped = g.slipped || slipped;
    }
    s.grasped = grasped;
  }
  for (std::size_t i = 0; i < tools; ++i) {
    ToolMetrics& tool = m.tools[i];
    tool.tool = static_cast<int>(i + 1);
    tool.mean_force_in_contact_n = state[i].contact_ticks ? state[i].force_sum / state[i].contact_ticks : 0.0;
    tool.mean_speed_mm_s = m.duration_s > 0.0 ? tool.path_length_mm / m.duration_s : 0.0;
    const State& s = state[i];
    const double shortest = s.shortest + (s.last - s.place).norm();
    tool.economy_of_motion = tool.path_length_mm > 1e-9 ? std::min(1.0, shortest / tool.path_length_mm) : 1.0;
    tool.mean_squared_jerk = s.jerks ? s.jerk_squares / static_cast<double>(s.jerks) : 0.0;
    tool.force = force[i].maxima();
    tool.model_force = model_force[i].maxima();
    tool.depth = depth[i].maxima();
    tool.speed.values.assign(kBuckets, kNaN);
    for (std::size_t b = 0; b < kBuckets; ++b)  // the path over the time the bucket's ticks span
      if (elapsed[i].sum[b] > 0.0) tool.speed.values[b] = path[i].sum[b] / elapsed[i].sum[b];
  }

  // The surface's strain: each triangle's peak, its rest area from the surface.
  m.strain_limit = strain_limit;
  std::vector<Eigen::Vector3d> vertices;
  CsvRows surface(dir / "surface.csv", 4);
  while (surface.next(row)) vertices.emplace_back(row[0], row[1], row[2]);
  CsvRows faces(dir / "triangles.csv", 3, 4);  // no strain column in runs recorded before it
  while (faces.next(row)) {
    if (row.size() < 4) continue;
    const auto index = [&](double x) {
      const auto v = static_cast<std::size_t>(x);
      if (v >= vertices.size())
        throw std::runtime_error(
            fmt::format("{}: vertex {} beyond the surface's {}", (dir / "triangles.csv").string(), v, vertices.size()));
      return v;
    };
    const Eigen::Vector3d &a = vertices[index(row[0])], &b = vertices[index(row[1])], &c = vertices[index(row[2])];
    m.largest_strain = std::max(m.largest_strain, row[3]);
    if (row[3] > strain_limit) m.damaged_area_mm2 += 0.5 * (b - a).cross(c - a).norm();
  }

  const double rest_volume = m.run.value("rest_volume_ml", 0.0);
  Accumulator volume(kBuckets);
  CsvRows frames(dir / "frames.csv", 2);
  while (frames.next(row)) {
    if (rest_volume <= 0.0) break;
    const double change = 100.0 * (row[1] / rest_volume - 1.0);
    volume.add(bucket_of(row[0]), change);
    if (std::abs(change) > std::abs(m.largest_volume_change_percent)) m.largest_volume_change_percent = change;
  }
  m.volume_change_percent = volume.means();
  return m;
}

nlohmann::json metrics_json(const RunMetrics& m) {
  nlohmann::json tools = nlohmann::json::array();
  for (const ToolMetrics& t : m.tools) {
    nlohmann::json events = nlohmann::json::array();
    for (const LimitEvent& e : t.events)
      events.push_back({{"start_s", e.start_s},
                        {"duration_s", e.duration_s},
                        {"peak_model_force_n", e.peak_force_n},
                        {"where_mm", {e.where_mm[0], e.where_mm[1], e.where_mm[2]}}});
    nlohmann::json grasps = nlohmann::json::array();
    for (const GraspEvent& g : t.grasps)
      grasps.push_back({{"start_s", g.start_s},
                        {"duration_s", g.duration_s},
                        {"peak_model_force_n", g.peak_force_n},
                        {"where_mm", {g.where_mm[0], g.where_mm[1], g.where_mm[2]}},
                        {"slipped", g.slipped}});
    tools.push_back({{"tool", t.tool},
                     {"peak_force_n", t.peak_force_n},
                     {"mean_force_in_contact_n", t.mean_force_in_contact_n},
                     {"peak_model_force_n", t.peak_model_force_n},
                     {"time_in_contact_s", t.time_in_contact_s},
                     {"time_above_limit_s", t.time_above_limit_s},
                     {"events_above_limit", t.events.size()},
                     {"events", events},
                     {"grasps", grasps},
                     {"grasp_slips",
                      std::count_if(t.grasps.begin(), t.grasps.end(), [](const GraspEvent& g) { return g.slipped; })},
                     {"path_length_mm", t.path_length_mm},
                     {"peak_depth_mm", t.peak_depth_mm},
                     {"mean_speed_mm_s", t.mean_speed_mm_s},
                     {"economy_of_motion", t.economy_of_motion},
                     {"mean_squared_jerk_mm2_s6", t.mean_squared_jerk},
                     {"idle_time_s", t.idle_time_s},
                     {"force_ticks", t.ticks},
                     {"invalid_pose_ticks", t.invalid_pose_ticks}});
  }
  return {{"duration_s", m.duration_s},
          {"force_limit_n", m.force_limit_n},
          {"deformation_model", m.run.value("deformation_model", "")},
          {"model_sha256", m.run.value("model_sha256", "")},
          {"largest_volume_change_percent", m.largest_volume_change_percent},
          {"strain_limit", m.strain_limit},
          {"largest_surface_strain", m.largest_strain},
          {"damaged_area_mm2", m.damaged_area_mm2},
          {"loop_health", m.run.value("loop_health", nlohmann::json::object())},
          {"tools", tools}};
}

std::vector<std::string> write_report(const std::string& directory, const ReportOptions& options) {
  const RunMetrics metrics = compute_metrics(directory, options.force_limit_n, options.strain_limit);
  std::unique_ptr<RunMetrics> reference;
  if (!options.reference_run.empty())
    reference = std::make_unique<RunMetrics>(
        compute_metrics(options.reference_run, options.force_limit_n, options.strain_limit));
  std::unique_ptr<Proficiency> proficiency;
  if (!options.expert_bands.empty())
    proficiency = std::make_unique<Proficiency>(judge(metrics, read_expert_bands(options.expert_bands)));
  const Pictures pictures = render_organ(directory, metrics);
  nlohmann::json document = metrics_json(metrics);
  if (proficiency) {
    nlohmann::json checks = nlohmann::json::array();
    for (const Proficiency::Check& c : proficiency->checks)
      checks.push_back({{"measure", c.measure.key},
                        {"tool", c.measure.tool},
                        {"value", c.measure.value},
                        {"low", c.band.low},
                        {"high", c.band.high},
                        {"within", c.within}});
    document["proficiency"] = {
        {"within", proficiency->within}, {"measures", proficiency->checks.size()}, {"checks", checks}};
  }
  nlohmann::json views = nlohmann::json::array();
  for (const Pictures::View& view : pictures.views) {
    nlohmann::json entry = {{"title", view.title}};
    if (view.deepest_pixel) entry["deepest_point_pixel"] = {(*view.deepest_pixel)[0], (*view.deepest_pixel)[1]};
    views.push_back(entry);
  }
  document["pictures"] = views;
  io::write_file_atomically((fs::path(directory) / "metrics.json").string(), document.dump(2) + "\n");
  io::write_file_atomically((fs::path(directory) / "index.html").string(),
                            page(metrics, reference.get(), proficiency.get(), pictures));
  return pictures.problems;
}

std::vector<Measure> skill_measures(const RunMetrics& metrics) { return skill_measures_of(metrics); }

std::map<std::string, Band> read_expert_bands(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot read the expert bands");
  const nlohmann::json j = nlohmann::json::parse(in, nullptr, false);
  if (!j.is_object())
    throw std::runtime_error(path + ": expert bands are one JSON object, {\"KEY\": [LOW, HIGH], ...}");
  RunMetrics example;
  example.tools.resize(1);
  std::vector<std::string> keys;
  for (const Measure& m : skill_measures_of(example)) keys.push_back(m.key);
  std::map<std::string, Band> bands;
  for (const auto& [key, value] : j.items()) {
    if (std::find(keys.begin(), keys.end(), key) == keys.end())
      throw std::runtime_error(
          fmt::format("{}: unknown measure '{}' (the measures: {})", path, key, fmt::join(keys, ", ")));
    if (!value.is_array() || value.size() != 2 || !value[0].is_number() || !value[1].is_number() ||
        !(value[0].get<double>() <= value[1].get<double>()))
      throw std::runtime_error(fmt::format("{}: '{}' must be [LOW, HIGH], two numbers with LOW <= HIGH", path, key));
    bands[key] = {value[0].get<double>(), value[1].get<double>()};
  }
  return bands;
}

void write_history(const std::vector<std::string>& directories, const ReportOptions& options,
                   const std::string& output) {
  if (directories.empty()) throw std::runtime_error("a learning curve needs at least one report directory");
  std::vector<std::vector<Measure>> attempts;
  std::vector<std::string> dates;
  for (const std::string& directory : directories) {
    const RunMetrics m = compute_metrics(directory, options.force_limit_n, options.strain_limit);
    attempts.push_back(skill_measures_of(m));
    dates.push_back(m.run.value("date", ""));
  }
  const std::map<std::string, Band> bands =
      options.expert_bands.empty() ? std::map<std::string, Band>{} : read_expert_bands(options.expert_bands);
  static const char* const kToolColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd"};
  std::string html =
      "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n"
      "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; style-src 'unsafe-inline'; "
      "img-src data:\">\n<title>organsim learning curve</title>\n<style>\n"
      "body{font-family:sans-serif;margin:1.5em;max-width:1100px;color:#222}"
      "table{border-collapse:collapse;margin:0.5em 0}td,th{border:1px solid #bbb;padding:3px 8px;text-align:left}"
      "th{background:#eee}svg{background:#fff}"
      "@media print{body{margin:0;max-width:none}svg,table{break-inside:avoid}}\n</style></head><body>\n";
  html += fmt::format("<h1>Learning curve</h1>\n<p>{} attempt{}, each measure over them{}.</p>\n", attempts.size(),
                      attempts.size() == 1 ? "" : "s",
                      bands.empty() ? "" : "; the expert band shaded green where one is given");
  // One chart per measure key: the run's value, or each tool's, over the attempts.
  std::vector<std::string> keys;
  for (const std::vector<Measure>& attempt : attempts)
    for (const Measure& m : attempt)
      if (std::find(keys.begin(), keys.end(), m.key) == keys.end()) keys.push_back(m.key);
  for (const std::string& key : keys) {
    std::map<int, ChartSeries> by_tool;
    std::string label, unit;
    for (std::size_t a = 0; a < attempts.size(); ++a)
      for (const Measure& m : attempts[a]) {
        if (m.key != key) continue;
        label = m.label;
        unit = m.unit;
        ChartSeries& series = by_tool[m.tool];
        if (series.name.empty()) {
          series.name = m.tool > 0 ? fmt::format("tool {}", m.tool) : "the run";
          series.colour = kToolColours[static_cast<std::size_t>(m.tool) % std::size(kToolColours)];
        }
        series.x.push_back(static_cast<double>(a + 1));
        series.y.push_back(m.value);
      }
    std::vector<ChartSeries> series;
    for (auto& [tool, s] : by_tool) series.push_back(std::move(s));
    ChartAxes axes = labelled_axes("attempt", unit.empty() ? label : fmt::format("{} ({})", label, unit));
    axes.points = true;
    if (const auto band = bands.find(key); band != bands.end()) {
      axes.band_low = band->second.low;
      axes.band_high = band->second.high;
      axes.band_label = "expert band";
    }
    html += fmt::format("<h2>{}</h2>\n", escape(label)) + svg_chart(series, axes);
  }
  html += "<h2>Every attempt</h2>\n<table><tr><th>attempt</th><th>recorded</th>";
  for (const Measure& m : attempts.front()) html += "<th>" + escape(measure_name(m)) + "</th>";
  html += "</tr>\n";
  for (std::size_t a = 0; a < attempts.size(); ++a) {
    html += fmt::format("<tr><td>{}</td><td>{}</td>", a + 1, escape(dates[a]));
    for (const Measure& m : attempts[a]) html += "<td>" + escape(measure_value_text(m)) + "</td>";
    html += "</tr>\n";
  }
  html += "</table>\n</body></html>\n";
  io::write_file_atomically(output, html);
}

}  // namespace organsim::report

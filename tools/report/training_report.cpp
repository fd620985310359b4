#include "training_report.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <utility>
#include <stdexcept>

#include <fmt/format.h>
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
  std::vector<std::pair<std::string, std::string>> views;  // title, data URI
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
  CsvRows triangles(directory / "triangles.csv", 3);
  while (triangles.next(row))
    picture.triangles.push_back(
        {static_cast<std::int32_t>(row[0]), static_cast<std::int32_t>(row[1]), static_cast<std::int32_t>(row[2])});
  for (const ToolMetrics& tool : metrics.tools)
    for (const LimitEvent& e : tool.events) picture.markers.push_back({e.where_mm[0], e.where_mm[1], e.where_mm[2]});
  picture.marker_radius = 3.0;
  picture.scale_title = "deepest indentation (mm)";
  picture.low = 0.0;
  picture.high = std::max(deepest, 1e-3);
  picture.width = 420;
  picture.height = 380;
  // LPS: anterior is −y, superior +z, the patient's right −x.
  const struct {
    const char* title;
    std::array<double, 3> direction, up;
  } sides[] = {{"front (anterior)", {0, 1, 0}, {0, 0, 1}},
               {"right side", {1, 0, 0}, {0, 0, 1}},
               {"top (superior)", {0, 0, -1}, {0, -1, 0}}};
  Pictures pictures;
  for (const auto& side : sides) {
    picture.title = side.title;
    picture.view_direction = side.direction;
    picture.view_up = side.up;
    try {
      const std::vector<unsigned char> png = draw_surface_png(picture);
      std::string encoded(png.size() * 4 / 3 + 8, '\0');
      const unsigned long length =
          vtkBase64Utilities::Encode(png.data(), png.size(), reinterpret_cast<unsigned char*>(encoded.data()));
      encoded.resize(length);
      pictures.views.emplace_back(side.title, "data:image/png;base64," + encoded);
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
        {"mean tip speed", t.mean_speed_mm_s, r ? r->mean_speed_mm_s : 0, "mm/s"}};
    for (const auto& row : rows) {
      const int digits = row.count ? 0 : 3;
      html +=
          fmt::format("<tr><td>{}</td><td>{}</td><td>{:.{}f} {}</td>", t.tool, row.name, row.ours, digits, row.unit);
      if (reference)
        html += r ? fmt::format("<td>{:.{}f} {}</td><td>{:+.{}f} {}</td>", row.theirs, digits, row.unit,
                                row.ours - row.theirs, digits, row.unit)
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

std::string page(const RunMetrics& m, const RunMetrics* reference, const Pictures& pictures) {
  const nlohmann::json& run = m.run;
  std::string html;
  html +=
      "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n"
      "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; style-src 'unsafe-inline'; "
      "img-src data:\">\n<title>organsim training report</title>\n<style>\n"
      "body{font-family:sans-serif;margin:1.5em;max-width:1100px;color:#222}"
      "table{border-collapse:collapse;margin:0.5em 0}td,th{border:1px solid #bbb;padding:3px 8px;text-align:left}"
      "th{background:#eee}.warn{color:#a00;font-weight:bold}.ok{color:#060}"
      "figure{display:inline-block;margin:0.3em}svg{background:#fff}\n</style></head><body>\n";
  html += "<h1>Training report</h1>\n<table>\n";
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

  html += "<h2>Per tool</h2>\n";
  if (reference)
    html += fmt::format("<p>Compared with a reference run of the {} model ({:.2f} s, recorded {}).</p>\n",
                        escape(reference->run.value("deformation_model", "")), reference->duration_s,
                        escape(reference->run.value("date", "")));
  if (reference) html += session_table(m, *reference);
  html += tool_table(m, reference);

  const std::vector<double> t = bucket_times(m);
  for (std::size_t i = 0; i < m.tools.size(); ++i) {
    const ToolMetrics& tool = m.tools[i];
    html += fmt::format("<h3>Tool {}</h3>\n", tool.tool);
    std::vector<ChartSeries> force{{"force sent", "#1f77b4", t, tool.force.values},
                                   {"model force", "#ff7f0e", t, tool.model_force.values}};
    if (reference && i < reference->tools.size())
      force.push_back({"reference: force sent", "#2ca02c", bucket_times(*reference), reference->tools[i].force.values});
    // The grasps and the stretches above the limit, shaded on the force chart.
    ChartAxes force_axes{"time (s)", "force (N)", m.force_limit_n, "limit", {}};
    for (const GraspEvent& g : tool.grasps)
      force_axes.spans.push_back({g.start_s, g.start_s + g.duration_s, g.slipped ? "#d62728" : "#2ca02c",
                                  g.slipped ? "grasp that slipped" : "grasp"});
    for (const LimitEvent& e : tool.events)
      force_axes.spans.push_back({e.start_s, e.start_s + e.duration_s, "#ff0000", "above the limit"});
    html += svg_chart(force, force_axes);
    html += svg_chart({{"indentation depth", "#9467bd", t, tool.depth.values}}, {"time (s)", "depth (mm)", 0.0, ""});
    html += svg_chart({{"tip speed", "#d62728", t, tool.speed.values}}, {"time (s)", "speed (mm/s)", 0.0, ""});
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
      "<h2>The organ</h2>\n<p>The surface coloured by the deepest indentation each point reached; black balls "
      "mark where a force went above the limit.</p>\n";
  for (const auto& [title, uri] : pictures.views)
    html += fmt::format("<figure><img alt=\"{}\" src=\"{}\"><figcaption>{}</figcaption></figure>\n", escape(title), uri,
                        escape(title));
  for (const std::string& problem : pictures.problems) html += "<p class=\"warn\">" + escape(problem) + "</p>\n";
  html += svg_chart({{"volume change", "#17becf", t, m.volume_change_percent.values}},
                    {"time (s)", "volume change (%)", 0.0, ""});
  html += "</body></html>\n";
  return html;
}

}  // namespace

RunMetrics compute_metrics(const std::string& directory, double force_limit_n) {
  if (!(force_limit_n > 0.0) || !std::isfinite(force_limit_n))
    throw std::runtime_error("the force limit must be a positive number of newtons");
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
    bool above = false, tip_valid = false, grasped = false;
    Eigen::Vector3d tip = Eigen::Vector3d::Zero();
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
    tool.force = force[i].maxima();
    tool.model_force = model_force[i].maxima();
    tool.depth = depth[i].maxima();
    tool.speed.values.assign(kBuckets, kNaN);
    for (std::size_t b = 0; b < kBuckets; ++b)  // the path over the time the bucket's ticks span
      if (elapsed[i].sum[b] > 0.0) tool.speed.values[b] = path[i].sum[b] / elapsed[i].sum[b];
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
                     {"force_ticks", t.ticks},
                     {"invalid_pose_ticks", t.invalid_pose_ticks}});
  }
  return {{"duration_s", m.duration_s},
          {"force_limit_n", m.force_limit_n},
          {"deformation_model", m.run.value("deformation_model", "")},
          {"model_sha256", m.run.value("model_sha256", "")},
          {"largest_volume_change_percent", m.largest_volume_change_percent},
          {"loop_health", m.run.value("loop_health", nlohmann::json::object())},
          {"tools", tools}};
}

std::vector<std::string> write_report(const std::string& directory, const ReportOptions& options) {
  const RunMetrics metrics = compute_metrics(directory, options.force_limit_n);
  std::unique_ptr<RunMetrics> reference;
  if (!options.reference_run.empty())
    reference = std::make_unique<RunMetrics>(compute_metrics(options.reference_run, options.force_limit_n));
  const Pictures pictures = render_organ(directory, metrics);
  io::write_file_atomically((fs::path(directory) / "metrics.json").string(), metrics_json(metrics).dump(2) + "\n");
  io::write_file_atomically((fs::path(directory) / "index.html").string(), page(metrics, reference.get(), pictures));
  return pictures.problems;
}

}  // namespace organsim::report

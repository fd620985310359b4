#include "organsim/devices/session_file.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "organsim/io/atomic_file.h"

namespace organsim::devices {
namespace {

[[noreturn]] void fail(const std::string& path, std::size_t line, const std::string& what) {
  throw std::runtime_error(path + ":" + std::to_string(line) + ": " + what);
}

std::string fmt(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", value);
  return text;
}

// A tool's number as a line gives it (1 to 16) -> its index.
std::size_t tool_index(const std::string& field, const std::string& path, std::size_t line) {
  char* stop = nullptr;
  const double value = std::strtod(field.c_str(), &stop);
  if (field.empty() || stop != field.c_str() + field.size() || !(value >= 1 && value <= 16) ||
      value != std::floor(value))
    fail(path, line, "tool numbers are 1 to 16");
  return static_cast<std::size_t>(value) - 1;
}

// A time stamp within the session's limits, s.
void check_time(double time, const SessionLimits& limits, const std::string& path, std::size_t line) {
  if (time < 0.0) fail(path, line, "times start at 0 s");
  if (time > limits.max_duration)
    fail(path, line,
         fmt(time) + " s is later than a session may last (" + fmt(limits.max_duration / 3600.0) +
             " h); check that times are in seconds, or pass --long-session to run it on purpose");
}

// Without overflow for coordinates near the largest doubles (AlignedBox's
// exteriorDistance squares them).
double distance_outside(const Eigen::AlignedBox3d& box, const Eigen::Vector3d& p) {
  const Eigen::Vector3d excess = (box.min() - p).cwiseMax(p - box.max()).cwiseMax(0.0);
  return excess.stableNorm();
}

}  // namespace

Session read_session(const std::string& path, const SessionLimits& limits) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open the session file; check the path");
  return parse_session(in, path, limits);
}

Session parse_session(std::istream& in, const std::string& path, const SessionLimits& limits) {
  static const std::string kHeader = "# organsim session ";
  static const std::string kNotASession =
      "not an organsim session (the first line must be '# organsim session 1', '2' or '3')";
  Session session;
  std::string text;
  std::size_t line_number = 0;
  int version = 0;
  while (std::getline(in, text)) {
    ++line_number;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    if (text.empty()) continue;
    if (text[0] == '#') {
      if (line_number == 1) {
        if (text.rfind(kHeader, 0) != 0) fail(path, 1, kNotASession);
        const std::string rest = text.substr(kHeader.size());
        const std::string number = rest.substr(0, rest.find(' '));
        if (number != "1" && number != "2" && number != "3")
          fail(path, 1, "session format version '" + number + "' is not one this organsim reads (1, 2 or 3)");
        version = number[0] - '0';
      }
      continue;
    }
    if (version == 0) fail(path, line_number, kNotASession);
    if (text.rfind("tip,", 0) == 0) {
      // tip,TOOL,RADIUS_MM: the tool's hemispherical end (version 2).
      if (version < 2) fail(path, line_number, "a 'tip' line needs format version 2 ('# organsim session 2')");
      if (std::count(text.begin(), text.end(), ',') != 2)
        fail(path, line_number, "expected tip,TOOL,RADIUS_MM (the tool's tip radius in millimetres)");
      const std::size_t comma = text.find(',', 4);
      const std::string tool_field = text.substr(4, comma - 4), radius_field = text.substr(comma + 1);
      const std::size_t tool = tool_index(tool_field, path, line_number);
      char* stop = nullptr;
      const double radius = std::strtod(radius_field.c_str(), &stop);
      if (radius_field.empty() || stop != radius_field.c_str() + radius_field.size() || !(radius >= 0.0) ||
          !(radius * 1e-3 <= kMaxTipRadius))
        fail(path, line_number,
             "'" + radius_field + "' is not a tip radius: a number of millimetres from 0 to " +
                 fmt(kMaxTipRadius * 1e3));
      if (tool >= session.tools.size()) session.tools.resize(tool + 1);
      if (session.tools[tool].tip_radius >= 0.0)
        fail(path, line_number, "tool " + std::to_string(tool + 1) + " has a second tip line");
      session.tools[tool].tip_radius = radius * 1e-3;
      continue;
    }
    if (text.rfind("jaw,", 0) == 0) {
      // jaw,TOOL,TIME_S,closed|open: a grasper's jaws from that time on (version 3).
      if (version < 3) fail(path, line_number, "a 'jaw' line needs format version 3 ('# organsim session 3')");
      if (std::count(text.begin(), text.end(), ',') != 3)
        fail(path, line_number, "expected jaw,TOOL,TIME_S,closed or jaw,TOOL,TIME_S,open");
      const std::size_t first = text.find(',', 4), second = text.find(',', first + 1);
      const std::string tool_field = text.substr(4, first - 4), time_field = text.substr(first + 1, second - first - 1),
                        state = text.substr(second + 1);
      const std::size_t tool = tool_index(tool_field, path, line_number);
      char* stop = nullptr;
      const double time = std::strtod(time_field.c_str(), &stop);
      if (time_field.empty() || stop != time_field.c_str() + time_field.size() || !std::isfinite(time))
        fail(path, line_number, "'" + time_field + "' is not a finite number");
      check_time(time, limits, path, line_number);
      if (state != "closed" && state != "open")
        fail(path, line_number, "'" + state + "' is not a jaw state: write closed or open");
      if (tool >= session.tools.size()) session.tools.resize(tool + 1);
      Trajectory& t = session.tools[tool];
      if (!t.jaw_times.empty() && time <= t.jaw_times.back())
        fail(path, line_number, "jaw times of a tool must increase");
      t.jaw_times.push_back(time);
      t.jaw_closed.push_back(state == "closed" ? 1 : 0);
      session.duration = std::max(session.duration, time);
      continue;
    }
    const auto fields = static_cast<int>(std::count(text.begin(), text.end(), ',')) + 1;
    if (fields != 5 && fields != 8)
      fail(path, line_number,
           "expected 5 or 8 comma-separated fields: time_s,tool,x_mm,y_mm,z_mm[,shaft_x,shaft_y,shaft_z]");
    double values[8];
    std::size_t start = 0;
    for (int k = 0; k < fields; ++k) {
      const std::size_t end = k + 1 < fields ? text.find(',', start) : text.size();
      const std::string field = text.substr(start, end - start);
      char* stop = nullptr;
      values[k] = std::strtod(field.c_str(), &stop);
      if (field.empty() || stop != field.c_str() + field.size() || !std::isfinite(values[k]))
        fail(path, line_number, "'" + field + "' is not a finite number");
      start = end + 1;
    }
    const double tool_value = values[1];
    if (tool_value < 1 || tool_value > 16 || tool_value != std::floor(tool_value))
      fail(path, line_number, "tool numbers are 1 to 16");
    const auto tool = static_cast<std::size_t>(tool_value) - 1;
    if (tool >= session.tools.size()) session.tools.resize(tool + 1);
    Trajectory& t = session.tools[tool];
    check_time(values[0], limits, path, line_number);
    if (!t.times.empty() && values[0] <= t.times.back()) fail(path, line_number, "times of a tool must increase");
    if (!t.times.empty() && t.shafts.empty() != (fields == 5))
      fail(path, line_number, "a tool's samples must all have a shaft direction or all have none");
    const Eigen::Vector3d tip(values[2] * 1e-3, values[3] * 1e-3, values[4] * 1e-3);
    if (!limits.organ_box.isEmpty() && distance_outside(limits.organ_box, tip) > limits.max_distance)
      fail(path, line_number,
           "tool " + std::to_string(tool + 1) + " is " + fmt(distance_outside(limits.organ_box, tip)) +
               " m from the organ (at most " + fmt(limits.max_distance) +
               " m); check that positions are in millimetres in the model's frame");
    t.times.push_back(values[0]);
    t.positions.push_back(tip);
    if (fields == 8) {
      const Eigen::Vector3d shaft(values[5], values[6], values[7]);
      const double length = shaft.stableNorm();  // no overflow for components near the largest doubles
      if (!(length > 0.0)) fail(path, line_number, "the shaft direction is zero");
      t.shafts.push_back(shaft / length);
    }
    session.duration = std::max(session.duration, values[0]);
  }
  if (session.tools.empty()) fail(path, line_number, "the session has no samples");
  for (std::size_t k = 0; k < session.tools.size(); ++k)
    if (session.tools[k].times.empty())
      throw std::runtime_error(path + ": tool " + std::to_string(k + 1) + " has no samples; number tools 1..N");
  return session;
}

void write_session(const Session& session, const std::string& path) {
  std::ostringstream out;
  const bool tips =
      std::any_of(session.tools.begin(), session.tools.end(), [](const Trajectory& t) { return t.tip_radius >= 0.0; });
  const bool jaws =
      std::any_of(session.tools.begin(), session.tools.end(), [](const Trajectory& t) { return !t.jaw_times.empty(); });
  out << (jaws   ? "# organsim session 3\n"
          : tips ? "# organsim session 2\n"
                 : "# organsim session 1\n")
      << "# time_s,tool,x_mm,y_mm,z_mm[,shaft_x,shaft_y,shaft_z] (model frame)\n";
  char line[200];
  for (std::size_t k = 0; k < session.tools.size(); ++k)
    if (session.tools[k].tip_radius >= 0.0) {
      std::snprintf(line, sizeof line, "tip,%zu,%.6g\n", k + 1, session.tools[k].tip_radius * 1e3);
      out << line;
    }
  for (std::size_t k = 0; k < session.tools.size(); ++k)
    for (std::size_t i = 0; i < session.tools[k].jaw_times.size(); ++i) {
      std::snprintf(line, sizeof line, "jaw,%zu,%.4f,%s\n", k + 1, session.tools[k].jaw_times[i],
                    session.tools[k].jaw_closed[i] ? "closed" : "open");
      out << line;
    }
  for (std::size_t k = 0; k < session.tools.size(); ++k)
    for (std::size_t i = 0; i < session.tools[k].times.size(); ++i) {
      const Eigen::Vector3d p = session.tools[k].positions[i] * 1e3;
      std::snprintf(line, sizeof line, "%.4f,%zu,%.3f,%.3f,%.3f", session.tools[k].times[i], k + 1, p[0], p[1], p[2]);
      out << line;
      if (!session.tools[k].shafts.empty()) {
        const Eigen::Vector3d& a = session.tools[k].shafts[i];
        std::snprintf(line, sizeof line, ",%.6f,%.6f,%.6f", a[0], a[1], a[2]);
        out << line;
      }
      out << '\n';
    }
  io::write_file_atomically(path, out.str());
}

}  // namespace organsim::devices

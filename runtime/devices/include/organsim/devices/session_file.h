// Session files: recorded tool trajectories (docs/session-format.md), read by
// `organsim replay` and `view --session` and played by ScriptedDevice.
#pragma once

#include <string>
#include <vector>

#include <iosfwd>
#include <limits>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/StdVector>

namespace organsim::devices {

/// One tool's path: tip positions (model frame, m) at increasing times (s), and
/// optionally the shaft direction (unit, from the tip towards the handle) at each.
struct Trajectory {
  std::vector<double> times;
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> positions;
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> shafts;  ///< empty, or one per time
  /// m: the radius of the tool's hemispherical end (a `tip` line, format
  /// version 2); negative when the file does not say (the command's --tip-radius).
  double tip_radius = -1.0;
  /// A grasper's jaws (`jaw` lines, format version 3): from jaw_times[k] (s,
  /// increasing) on they are closed when jaw_closed[k] is 1, open when 0; open
  /// before the first. Empty: a probe, whose jaws never close.
  std::vector<double> jaw_times;
  std::vector<unsigned char> jaw_closed;
};

struct Session {
  std::vector<Trajectory> tools;  ///< tool k is numbered k + 1 in files and reports
  double duration = 0.0;          ///< s, the last time stamp of any tool
};

/// What a session may hold. A session longer than a day, or a tool far from
/// the organ, is almost always a mistake (a time in milliseconds, coordinates
/// in micrometres or another frame) and would run for days or never touch it.
struct SessionLimits {
  double max_duration = 86400.0;  ///< s; infinity allows any length (replay --long-session)
  Eigen::AlignedBox3d organ_box;  ///< m; empty: tools are not checked against the organ
  double max_distance = 10.0;     ///< m, the farthest a tool tip may be from organ_box
};

/// Reads a session file. Throws std::runtime_error naming the file, the line and
/// what is wrong (syntax, non-finite values, times going back, missing tools,
/// beyond `limits`).
Session read_session(const std::string& path, const SessionLimits& limits = {});

/// The same from a stream; `name` (the file's path) starts each error message.
Session parse_session(std::istream& in, const std::string& name, const SessionLimits& limits = {});

/// m: the largest tip radius a session may give (a 10 cm wide instrument end
/// is a unit mistake).
constexpr double kMaxTipRadius = 0.05;

/// Writes a session file (for tools that make sessions): format version 3
/// when a tool has jaw events, else 2 when a tool has a tip radius, else 1
/// (which every organsim reads).
void write_session(const Session& session, const std::string& path);

}  // namespace organsim::devices

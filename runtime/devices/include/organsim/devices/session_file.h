// Session files: recorded tool trajectories (docs/session-format.md), read by
// `organsim replay` and `view --session` and played by ScriptedDevice.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/StdVector>

namespace organsim::devices {

/// One tool's path: tip positions (model frame, m) at increasing times (s), and
/// optionally the shaft direction (unit, from the tip towards the handle) at each.
struct Trajectory {
  std::vector<double> times;
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> positions;
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> shafts;  ///< empty, or one per time
};

struct Session {
  std::vector<Trajectory> tools;  ///< tool k is numbered k + 1 in files and reports
  double duration = 0.0;          ///< s, the last time stamp of any tool
};

/// Reads a session file. Throws std::runtime_error naming the file, the line and
/// what is wrong (syntax, non-finite values, times going back, missing tools).
Session read_session(const std::string& path);

/// Writes a session file (for tools that make sessions).
void write_session(const Session& session, const std::string& path);

}  // namespace organsim::devices

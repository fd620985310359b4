// Recorded tool trajectories (docs/session-format.md) and the scripted device
// that replays one of them and records the forces it receives: how force output
// is regression-tested without hardware.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/StdVector>

#include "organsim/realtime/haptic_device.h"

namespace organsim::realtime {

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

/// A force the device received.
struct ForceRecord {
  double time = 0.0;                               ///< s
  Eigen::Vector3d force = Eigen::Vector3d::Zero();  ///< N
  bool in_contact = false;
};

/// Plays a trajectory (linear between samples, the shaft direction normalized
/// after interpolation; held before the first and after the last sample) and
/// records every force written, up to `max_records`.
class ScriptedDevice final : public HapticDevice {
 public:
  ScriptedDevice(Trajectory trajectory, const SafetyLimits& limits, std::size_t max_records);

  const SafetyLimits& limits() const noexcept override { return limits_; }
  bool read_pose(double time, ToolPose& pose) noexcept override;
  void write_force(double time, const Eigen::Vector3d& force, bool in_contact) noexcept override;

  std::size_t record_count() const noexcept { return count_; }
  const ForceRecord& record(std::size_t i) const noexcept { return records_[i]; }
  std::size_t dropped_records() const noexcept { return dropped_; }

 private:
  Trajectory trajectory_;
  SafetyLimits limits_;
  std::size_t cursor_ = 0;
  std::vector<ForceRecord, Eigen::aligned_allocator<ForceRecord>> records_;
  std::size_t count_ = 0, dropped_ = 0;
};

}  // namespace organsim::realtime

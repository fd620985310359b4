// The scripted device: replays one recorded trajectory and records the forces
// it receives. How force output is regression-tested without hardware, and
// what `organsim replay` drives the engine with.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>
#include <Eigen/StdVector>

#include "organsim/devices/haptic_device.h"
#include "organsim/devices/session_file.h"

namespace organsim::devices {

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

}  // namespace organsim::devices

// The scripted device: replays one recorded trajectory and records the forces
// it receives. How force output is regression-tested without hardware, and
// what `organsim replay` drives the engine with.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>

#include "organsim/devices/haptic_device.h"
#include "organsim/devices/session_file.h"
#include "organsim/lockfree/spsc_ring.h"

namespace organsim::devices {

/// A force the device received.
struct ForceRecord {
  double time = 0.0;                                ///< s
  Eigen::Vector3d force = Eigen::Vector3d::Zero();  ///< N
  bool in_contact = false;
};

/// Plays a trajectory (linear between samples, the shaft direction normalized
/// after interpolation; held before the first and after the last sample, or
/// started again every `repeat_period` seconds when that is positive; the jaws
/// as the last jaw event at or before the time left them) and keeps the forces
/// written to it in a ring of `capacity` records.
///
/// The force loop writes records without allocating or locking; another thread
/// may take them out while it runs (take_record: one writer, one reader,
/// wait-free), so that a session of any length streams its forces through a
/// fixed buffer. A record that finds the ring full is dropped and counted.
/// Without a reader, the first `capacity` records stay in order (record(i)).
class ScriptedDevice final : public HapticDevice {
 public:
  ScriptedDevice(Trajectory trajectory, const SafetyLimits& limits, std::size_t capacity, double repeat_period = 0.0);

  const SafetyLimits& limits() const noexcept override { return limits_; }
  bool read_pose(double time, ToolPose& pose) noexcept override;
  void write_force(double time, const Eigen::Vector3d& force, bool in_contact) noexcept override;

  /// Records held (written and not yet taken).
  std::size_t record_count() const noexcept { return records_.size(); }
  /// The i-th oldest record held, i < record_count() (the reader's thread).
  const ForceRecord& record(std::size_t i) const noexcept { return records_.peek(i); }
  /// Moves the oldest record held into `out`; false when none is held.
  bool take_record(ForceRecord& out) noexcept { return records_.take(out); }
  std::size_t dropped_records() const noexcept { return records_.dropped(); }

 private:
  Trajectory trajectory_;
  SafetyLimits limits_;
  double repeat_period_;
  std::size_t cursor_ = 0;
  std::size_t jaw_cursor_ = 0;  // jaw events at or before the last time read
  lockfree::SpscRing<ForceRecord> records_;
};

}  // namespace organsim::devices

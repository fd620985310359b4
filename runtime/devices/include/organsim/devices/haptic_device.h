// One tool's input and force output, whatever the hardware: the interface every
// device implements (scripted, mouse, OpenHaptics; docs/realtime.md). The engine calls
// both functions from the force loop, so implementations must not allocate,
// lock, block or do I/O in them. Units are converted at this boundary: the
// engine sees the model frame in metres and newtons.
#pragma once

#include <Eigen/Core>

namespace organsim::devices {

/// A device's limits and the safety rules' time constants (SI). The engine's
/// force safety (organsim/realtime/force_safety.h) enforces them on every tick.
struct SafetyLimits {
  double max_force = 3.3;         ///< N: larger forces are scaled down to this magnitude (PHANToM Omni/Touch peak)
  double max_stiffness = 1000.0;  ///< N/m: stiffer contacts are softened to this (Omni/Touch ≈ 0.8–1.3 N/mm)
  double onset_rate = 40.0;       ///< N/s: how fast the force magnitude may grow (no kick at contact)
  double stall_timeout = 0.1;     ///< s without a fresh simulation frame before the force ramps down
  double ramp_down_time = 0.2;    ///< s from full force to zero once stalled
};

/// Where a tool is: its tip and, when the device knows it, its shaft; and,
/// for a grasper, whether its jaws are closed (docs/realtime.md#grasping).
struct ToolPose {
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();    ///< model frame, m
  Eigen::Vector3d shaft = Eigen::Vector3d::Zero();  ///< unit, from the tip towards the handle; zero when unknown
  bool jaws_closed = false;                         ///< a probe's are always open
};

class HapticDevice {
 public:
  virtual ~HapticDevice() = default;
  /// The device's force and stiffness limits (the engine never exceeds them).
  virtual const SafetyLimits& limits() const noexcept = 0;
  /// The tool's pose at `time` (s), model frame; false when unavailable.
  virtual bool read_pose(double time, ToolPose& pose) noexcept = 0;
  /// The force to render at `time` (s), on the user's hand, model frame, N;
  /// `in_contact` says whether the tool touches the organ.
  virtual void write_force(double time, const Eigen::Vector3d& force, bool in_contact) noexcept = 0;
};

}  // namespace organsim::devices

// One tool's input and force output, whatever the hardware. The engine calls
// both functions from the force loop, so implementations must not allocate,
// lock, block or do I/O in them. Units are converted at this boundary: the
// engine sees the model frame in metres and newtons.
#pragma once

#include <Eigen/Core>

#include "organsim/realtime/force_safety.h"

namespace organsim::realtime {

/// Where a tool is: its tip and, when the device knows it, its shaft.
struct ToolPose {
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();    ///< model frame, m
  Eigen::Vector3d shaft = Eigen::Vector3d::Zero();  ///< unit, from the tip towards the handle; zero when unknown
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

}  // namespace organsim::realtime

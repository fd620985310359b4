// What stands between the simulation and a haptic device: every force passes
// through here, on the force loop, once per tick. No allocation, lock or I/O.
#pragma once

#include <cstdint>

#include <Eigen/Core>

#include "organsim/devices/haptic_device.h"

namespace organsim::realtime {

using devices::SafetyLimits;

/// Per tool: clamp, NaN/Inf guard, watchdog ramp-down and onset rate limit.
class ForceSafety {
 public:
  ForceSafety() noexcept = default;
  explicit ForceSafety(const SafetyLimits& limits) noexcept : limits_(limits) {}

  /// The force to send for `requested` (N) at time `now` (s), `dt` (s) after the
  /// previous tick, when the simulation last published a frame at
  /// `last_frame_time` (s). Always finite and within the limits.
  Eigen::Vector3d filter(const Eigen::Vector3d& requested, double now, double last_frame_time, double dt) noexcept;

  std::uint64_t non_finite_count() const noexcept { return non_finite_; }  ///< NaN/Inf forces replaced by zero
  std::uint64_t clamp_count() const noexcept { return clamped_; }          ///< ticks limited to max_force
  std::uint64_t stalled_count() const noexcept { return stalled_; }        ///< ticks under the watchdog
  const SafetyLimits& limits() const noexcept { return limits_; }

 private:
  SafetyLimits limits_;
  double previous_magnitude_ = 0.0;
  std::uint64_t non_finite_ = 0, clamped_ = 0, stalled_ = 0;
};

}  // namespace organsim::realtime

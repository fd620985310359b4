#include "organsim/realtime/force_safety.h"

#include <algorithm>
#include <cmath>

namespace organsim::realtime {

Eigen::Vector3d ForceSafety::filter(const Eigen::Vector3d& requested, double now, double last_frame_time,
                                    double dt) noexcept {
  if (!requested.allFinite() || !std::isfinite(now) || !std::isfinite(last_frame_time)) {
    ++non_finite_;
    previous_magnitude_ = 0.0;  // resume with a ramp, not a kick
    return Eigen::Vector3d::Zero();
  }
  double magnitude = requested.norm();
  if (magnitude == 0.0) {
    previous_magnitude_ = 0.0;
    return Eigen::Vector3d::Zero();
  }
  if (magnitude > limits_.max_force) {
    ++clamped_;
    magnitude = limits_.max_force;
  }
  const double silence = now - last_frame_time;
  if (silence > limits_.stall_timeout) {  // the simulation stalled: fade out
    ++stalled_;
    magnitude *= std::clamp(1.0 - (silence - limits_.stall_timeout) / limits_.ramp_down_time, 0.0, 1.0);
  }
  // Growth is rate limited from what was actually sent; decrease is immediate.
  magnitude = std::min(magnitude, previous_magnitude_ + limits_.onset_rate * std::max(dt, 0.0));
  previous_magnitude_ = magnitude;
  return requested * (magnitude / requested.norm());
}

}  // namespace organsim::realtime

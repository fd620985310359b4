#include "organsim/devices/scripted_device.h"

#include <cmath>

namespace organsim::devices {

ScriptedDevice::ScriptedDevice(Trajectory trajectory, const SafetyLimits& limits, std::size_t capacity,
                               double repeat_period)
    : trajectory_(std::move(trajectory)),
      limits_(limits),
      repeat_period_(repeat_period > 0.0 ? repeat_period : 0.0),
      records_(capacity) {}

bool ScriptedDevice::read_pose(double time, ToolPose& pose) noexcept {
  const auto& times = trajectory_.times;
  if (times.empty() || !std::isfinite(time)) return false;
  if (repeat_period_ > 0.0) time = std::fmod(time, repeat_period_);
  if (cursor_ > 0 && times[cursor_ - 1] > time) cursor_ = 0;  // time went back
  while (cursor_ < times.size() && times[cursor_] <= time) ++cursor_;
  const bool has_shaft = !trajectory_.shafts.empty();
  pose.shaft.setZero();
  if (cursor_ == 0 || cursor_ == times.size()) {
    const std::size_t i = cursor_ == 0 ? 0 : times.size() - 1;
    pose.tip = trajectory_.positions[i];
    if (has_shaft) pose.shaft = trajectory_.shafts[i];
  } else {
    const double s = (time - times[cursor_ - 1]) / (times[cursor_] - times[cursor_ - 1]);
    pose.tip = (1.0 - s) * trajectory_.positions[cursor_ - 1] + s * trajectory_.positions[cursor_];
    if (has_shaft) {
      const Eigen::Vector3d shaft = (1.0 - s) * trajectory_.shafts[cursor_ - 1] + s * trajectory_.shafts[cursor_];
      if (shaft.norm() > 0.0) pose.shaft = shaft.normalized();
    }
  }
  const auto& jaw_times = trajectory_.jaw_times;
  if (jaw_cursor_ > 0 && jaw_times[jaw_cursor_ - 1] > time) jaw_cursor_ = 0;
  while (jaw_cursor_ < jaw_times.size() && jaw_times[jaw_cursor_] <= time) ++jaw_cursor_;
  pose.jaws_closed = jaw_cursor_ > 0 && trajectory_.jaw_closed[jaw_cursor_ - 1] != 0;
  return true;
}

void ScriptedDevice::write_force(double time, const Eigen::Vector3d& force, bool in_contact) noexcept {
  records_.push({time, force, in_contact});
}

}  // namespace organsim::devices

// A tool whose pose another thread pushes: the viewer's mouse and keyboard, or
// poses arriving over the network (`organsim serve`, OpenIGTLink). A
// HapticDevice whose pose one thread sets and the force loop reads, and whose
// force the force loop sends and that thread reads back, both wait-free.
#pragma once

#include <atomic>

#include "organsim/devices/haptic_device.h"
#include "organsim/lockfree/triple_buffer.h"

namespace organsim::devices {

class StreamedTool final : public HapticDevice {
 public:
  explicit StreamedTool(const SafetyLimits& limits = {}) : limits_(limits) {}

  // --- the thread that pushes poses (one) ---
  /// Makes `pose` (model frame, m) the tool's pose from the next force tick on.
  void place(const ToolPose& pose) {
    poses_.write_slot() = {true, pose};
    poses_.publish();
  }
  /// The tool has no pose any more (removed, or its source is gone): its force fades to zero.
  void remove() {
    poses_.write_slot() = {false, {}};
    poses_.publish();
  }
  /// The last force the force loop sent (N), and whether the tool touched.
  Eigen::Vector3d last_force(bool& in_contact) {
    forces_.update();
    in_contact = forces_.read().in_contact;
    return forces_.read().force;
  }
  std::uint64_t ticks() const { return ticks_.load(std::memory_order_acquire); }

  // --- force loop ---
  const SafetyLimits& limits() const noexcept override { return limits_; }
  bool read_pose(double, ToolPose& pose) noexcept override {
    poses_.update();
    pose = poses_.read().pose;
    return poses_.read().present;
  }
  void write_force(double, const Eigen::Vector3d& force, bool in_contact) noexcept override {
    forces_.write_slot() = {force, in_contact};
    forces_.publish();
    ticks_.fetch_add(1, std::memory_order_release);  // the force above is published before the count
  }

 private:
  struct Placed {
    bool present = false;
    ToolPose pose;
  };
  struct Felt {
    Eigen::Vector3d force = Eigen::Vector3d::Zero();
    bool in_contact = false;
  };
  SafetyLimits limits_;
  lockfree::TripleBuffer<Placed> poses_;
  lockfree::TripleBuffer<Felt> forces_;
  std::atomic<std::uint64_t> ticks_{0};
};

}  // namespace organsim::devices

// PHANToM / Touch devices through the OpenHaptics HD API, loaded at run time
// (dlopen): organsim builds and runs without the vendor SDK and uses the
// devices when the HD library is installed. The HD servo scheduler drives the
// engine's force loop: each servo tick reads every device, runs one force
// tick, and commits the forces.
//
// Units are converted here: HD positions are millimetres in the device frame,
// forces newtons, stiffness N/mm; the engine sees the model frame in metres.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "organsim/devices/force_loop.h"
#include "organsim/devices/haptic_device.h"
#include "organsim/lockfree/triple_buffer.h"

namespace organsim::devices {

/// The HD library's entry points, resolved with dlopen/dlsym.
class HdLibrary {
 public:
  /// Loads `path` ("libHD.so" by default: the system's search path). Throws
  /// std::runtime_error saying which library or symbol is missing and what to do.
  explicit HdLibrary(const std::string& path = "libHD.so");
  ~HdLibrary();
  HdLibrary(const HdLibrary&) = delete;
  HdLibrary& operator=(const HdLibrary&) = delete;

  struct Api;
  const Api& api() const noexcept { return *api_; }

 private:
  void* handle_ = nullptr;
  std::unique_ptr<Api> api_;
};

/// Where a device's workspace sits in the model: p_model = offset + scale · R · p_device.
struct DevicePlacement {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  ///< m
  double scale = 1.0;                                ///< model metres per device metre
};

/// One HD device as a HapticDevice. read_pose/write_force must be called inside
/// the servo tick (between hdBeginFrame and hdEndFrame), as OpenHapticsServo does.
/// The shaft is the stylus axis: the +z column of HD_CURRENT_TRANSFORM (the
/// stylus points along −z, so +z runs from the tip towards the hand).
class OpenHapticsDevice final : public HapticDevice {
 public:
  /// Opens the device named `name` ("" = the default device) and enables force
  /// output. `limits` are lowered to the device's nominal maximum force and
  /// stiffness. Throws std::runtime_error when the device cannot be opened.
  OpenHapticsDevice(const HdLibrary& library, const std::string& name, const DevicePlacement& placement,
                    const SafetyLimits& limits);
  ~OpenHapticsDevice() override;

  const SafetyLimits& limits() const noexcept override { return limits_; }
  bool read_pose(double time, ToolPose& pose) noexcept override;
  void write_force(double time, const Eigen::Vector3d& force, bool in_contact) noexcept override;

  std::uint32_t handle() const noexcept { return handle_; }

  /// For drawing, from one other thread: the pose the servo last read (false
  /// before the first) and the force it last sent (N, model frame). Wait-free.
  bool last_pose(ToolPose& pose);
  Eigen::Vector3d last_force();

  /// Servo ticks in which the HD library reported an error for this device
  /// (hdGetError after reading the pose or sending the force: a communication
  /// error, a disconnected or faulted device), and the latest error code; from
  /// any thread. A tick with an error gives no pose, so the engine fades this
  /// tool's force to zero (ToolTelemetry::pose_faults).
  std::uint64_t error_ticks() const noexcept { return error_ticks_.load(std::memory_order_relaxed); }
  unsigned last_error() const noexcept { return last_error_.load(std::memory_order_relaxed); }

 private:
  struct Seen {
    bool valid = false;
    ToolPose pose;
  };
  const HdLibrary& library_;
  std::uint32_t handle_;
  DevicePlacement placement_;
  SafetyLimits limits_;
  lockfree::TripleBuffer<Seen> seen_;
  lockfree::TripleBuffer<Eigen::Vector3d> sent_{Eigen::Vector3d::Zero()};
  std::atomic<std::uint64_t> error_ticks_{0};
  std::atomic<unsigned> last_error_{0};
  bool error_this_tick_ = false;  // servo thread only
  bool note_error() noexcept;
};

/// Runs a force loop (the engine's: realtime::Engine is a ForceLoop) in the HD
/// servo scheduler (≈ 1 kHz) for the given devices, from start() to stop().
/// The deformation loop runs elsewhere.
class OpenHapticsServo {
 public:
  OpenHapticsServo(const HdLibrary& library, std::vector<OpenHapticsDevice*> devices, ForceLoop& loop);
  ~OpenHapticsServo();
  void start();
  void stop() noexcept;
  /// Servo ticks run so far (read from any thread).
  std::uint64_t ticks() const noexcept;

 private:
  static unsigned int tick(void* self) noexcept;
  const HdLibrary& library_;
  std::vector<OpenHapticsDevice*> devices_;
  ForceLoop& loop_;
  unsigned long schedule_ = 0;
  bool running_ = false;
  double start_time_ = 0.0;
  std::atomic<std::uint64_t> ticks_{0};  // written by the servo thread only
};

}  // namespace organsim::devices

// PHANToM / Touch devices for a command: the HD library, one device per tool
// placed in the model, ready for an Engine and an OpenHapticsServo. Shared by
// `organsim touch` and `organsim view --phantom`.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "organsim/devices/openhaptics.h"
#include "organsim/multibeam/beam_organ.h"

namespace organsim::cli {

struct HapticRigOptions {
  std::string library = "libHD.so";
  std::vector<std::string> devices;  ///< names; empty: the default device
  double scale = 1.0;
  std::vector<double> offset_mm;     ///< empty: 20 mm in front of the organ
  double max_force = realtime::SafetyLimits{}.max_force;

  void add_to(CLI::App& app);
};

struct HapticRig {
  std::unique_ptr<devices::HdLibrary> library;
  std::vector<std::unique_ptr<devices::OpenHapticsDevice>> devices;

  std::vector<realtime::HapticDevice*> tools() const;
  std::vector<devices::OpenHapticsDevice*> servo_devices() const;
};

/// Loads the HD library and opens the devices; throws std::runtime_error with
/// a one-line reason when it cannot.
HapticRig open_haptic_rig(const HapticRigOptions& options, const multibeam::BeamOrgan& organ);

}  // namespace organsim::cli

// The PHANToM / Touch devices of a session: the HD library and one device per
// tool, placed in the model's frame, ready for an Engine and an
// OpenHapticsServo. Shared by `organsim touch` and `organsim view --phantom`.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "organsim/openhaptics/openhaptics.h"
#include "organsim/model/organ_model.h"

namespace organsim::devices {

struct HapticRigOptions {
  std::string library = "libHD.so";  ///< the HD library to load
  std::vector<std::string> devices;  ///< names as configured in Touch Setup; empty: the default device
  double scale = 1.0;                ///< model millimetres per device millimetre
  std::vector<double> offset_mm;     ///< model point (mm) at the workspace centre; empty: 20 mm in front of the organ
  double max_force = SafetyLimits{}.max_force;  ///< N (the device's own maximum applies too)
};

struct HapticRig {
  std::unique_ptr<HdLibrary> library;
  std::vector<std::unique_ptr<OpenHapticsDevice>> devices;

  std::vector<HapticDevice*> tools() const;
  std::vector<OpenHapticsDevice*> servo_devices() const;
};

/// Loads the HD library and opens the devices for `model`; throws
/// std::runtime_error with a one-line reason when it cannot.
HapticRig open_haptic_rig(const HapticRigOptions& options, const model::OrganModel& model);

}  // namespace organsim::devices

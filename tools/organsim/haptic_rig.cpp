#include "haptic_rig.h"

#include "organsim/geometry/model_measures.h"

namespace organsim::cli {

void HapticRigOptions::add_to(CLI::App& app) {
  app.add_option("--hd-library", library, "The OpenHaptics HD library to load")->capture_default_str();
  app.add_option("--device", devices, "Device name as configured in Touch Setup (repeat for more tools; default: the default device)");
  app.add_option("--scale", scale, "Model millimetres per device millimetre")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--offset", offset_mm, "Model point X,Y,Z (mm) at the device's workspace centre (default: 20 mm in front of the organ)")
      ->expected(3)
      ->delimiter(',');
  app.add_option("--max-force", max_force, "Force limit, N (the device's own maximum applies too)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
}

std::vector<realtime::HapticDevice*> HapticRig::tools() const {
  std::vector<realtime::HapticDevice*> list;
  for (const auto& d : devices) list.push_back(d.get());
  return list;
}

std::vector<devices::OpenHapticsDevice*> HapticRig::servo_devices() const {
  std::vector<devices::OpenHapticsDevice*> list;
  for (const auto& d : devices) list.push_back(d.get());
  return list;
}

HapticRig open_haptic_rig(const HapticRigOptions& o, const multibeam::BeamOrgan& organ) {
  // By default the device's workspace centre sits 20 mm in front of the organ
  // (anterior: −y in LPS), so that the tool starts outside it.
  const ModelMeasures measures = measure_model(organ.model());
  devices::DevicePlacement placement;
  placement.scale = o.scale;
  if (o.offset_mm.size() == 3) {
    placement.offset = Eigen::Vector3d(o.offset_mm[0], o.offset_mm[1], o.offset_mm[2]) * 1e-3;
  } else {
    placement.offset = 0.5 * (measures.bounds_min + measures.bounds_max);
    placement.offset[1] = measures.bounds_min[1] - 0.02;
  }
  realtime::SafetyLimits limits;
  limits.max_force = o.max_force;
  HapticRig rig;
  rig.library = std::make_unique<devices::HdLibrary>(o.library);
  const std::vector<std::string> names = o.devices.empty() ? std::vector<std::string>{""} : o.devices;
  for (const std::string& name : names)
    rig.devices.push_back(std::make_unique<devices::OpenHapticsDevice>(*rig.library, name, placement, limits));
  return rig;
}

}  // namespace organsim::cli

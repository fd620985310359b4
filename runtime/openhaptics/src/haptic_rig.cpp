#include "organsim/openhaptics/haptic_rig.h"

#include <Eigen/Geometry>

namespace organsim::devices {

std::vector<HapticDevice*> HapticRig::tools() const {
  std::vector<HapticDevice*> list;
  for (const auto& d : devices) list.push_back(d.get());
  return list;
}

std::vector<OpenHapticsDevice*> HapticRig::servo_devices() const {
  std::vector<OpenHapticsDevice*> list;
  for (const auto& d : devices) list.push_back(d.get());
  return list;
}

HapticRig open_haptic_rig(const HapticRigOptions& o, const model::OrganModel& model) {
  // By default the device's workspace centre sits 20 mm in front of the organ
  // (anterior: −y in LPS), so that the tool starts outside it.
  Eigen::AlignedBox3d bounds;
  for (const model::Point3& p : model.surface_vertices) bounds.extend(Eigen::Vector3d(p[0], p[1], p[2]));
  DevicePlacement placement;
  placement.scale = o.scale;
  if (o.offset_mm.size() == 3) {
    placement.offset = Eigen::Vector3d(o.offset_mm[0], o.offset_mm[1], o.offset_mm[2]) * 1e-3;
  } else {
    placement.offset = bounds.center();
    placement.offset[1] = bounds.min()[1] - 0.02;
  }
  SafetyLimits limits;
  limits.max_force = o.max_force;
  HapticRig rig;
  rig.library = std::make_unique<HdLibrary>(o.library);
  const std::vector<std::string> names = o.devices.empty() ? std::vector<std::string>{""} : o.devices;
  for (const std::string& name : names)
    rig.devices.push_back(std::make_unique<OpenHapticsDevice>(*rig.library, name, placement, limits));
  return rig;
}

}  // namespace organsim::devices

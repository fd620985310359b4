#include "haptic_rig_options.h"

#include "command_line/command_line.h"

namespace organsim::cli {

void add_haptic_rig_options(CLI::App& app, devices::HapticRigOptions& o) {
  app.add_option("--hd-library", o.library, "The OpenHaptics HD library to load")->capture_default_str();
  app.add_option("--device", o.devices,
                 "Device name as configured in Touch Setup (repeat for more tools; default: the default device)");
  app.add_option("--scale", o.scale, "Model millimetres per device millimetre")
      ->check(kPositive)
      ->capture_default_str();
  app.add_option("--offset", o.offset_mm,
                 "Model point X,Y,Z (mm) at the device's workspace centre (default: 20 mm in front of the organ)")
      ->expected(3)
      ->delimiter(',');
  app.add_option("--max-force", o.max_force, "Force limit, N (the device's own maximum applies too)")
      ->check(kPositive)
      ->capture_default_str();
}

}  // namespace organsim::cli

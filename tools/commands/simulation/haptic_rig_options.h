// The command-line options of a PHANToM / Touch rig, shared by `organsim touch`
// and `organsim view --phantom`.
#pragma once

#include <CLI/CLI.hpp>

#include "organsim/openhaptics/haptic_rig.h"

namespace organsim::cli {

void add_haptic_rig_options(CLI::App& app, devices::HapticRigOptions& options);

}  // namespace organsim::cli

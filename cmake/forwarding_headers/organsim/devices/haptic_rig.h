// Moved to <organsim/openhaptics/haptic_rig.h> (docs/install.md). This forwarding header is
// installed for one release only, so that code built against the old path keeps
// compiling; include the new path.
#pragma once
#pragma message("<organsim/devices/haptic_rig.h> moved to <organsim/openhaptics/haptic_rig.h>")
#include "organsim/openhaptics/haptic_rig.h"

// Moved to <organsim/openhaptics/openhaptics.h> (docs/install.md). This forwarding header is
// installed for one release only, so that code built against the old path keeps
// compiling; include the new path.
#pragma once
#pragma message("<organsim/devices/openhaptics.h> moved to <organsim/openhaptics/openhaptics.h>")
#include "organsim/openhaptics/openhaptics.h"

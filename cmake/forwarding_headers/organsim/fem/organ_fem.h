// Moved to <organsim/organ_fem/organ_fem.h> (docs/install.md). This forwarding header is
// installed for one release only, so that code built against the old path keeps
// compiling; include the new path.
#pragma once
#pragma message("<organsim/fem/organ_fem.h> moved to <organsim/organ_fem/organ_fem.h>")
#include "organsim/organ_fem/organ_fem.h"

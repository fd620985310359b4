// Moved to <organsim/fem_direct/direct_factorizations.h> (docs/install.md). This forwarding header is
// installed for one release only, so that code built against the old path keeps
// compiling; include the new path.
#pragma once
#pragma message("<organsim/fem/direct_factorizations.h> moved to <organsim/fem_direct/direct_factorizations.h>")
#include "organsim/fem_direct/direct_factorizations.h"

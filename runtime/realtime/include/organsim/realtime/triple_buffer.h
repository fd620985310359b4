// Forwarding header, kept for one release (docs/install.md): the triple buffer
// moved to organsim/lockfree/triple_buffer.h (the interface library
// organsim::lockfree), below both the devices and the engine that use it.
#pragma once

#include "organsim/lockfree/triple_buffer.h"

namespace organsim::realtime {
using lockfree::TripleBuffer;
}  // namespace organsim::realtime

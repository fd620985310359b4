// What a device's own servo scheduler drives: one force tick at a time. The
// engine's force loop is one (realtime::Engine implements it); a backend that
// calls it (the OpenHaptics servo) needs nothing above the devices' floor.
#pragma once

namespace organsim::devices {

class ForceLoop {
 public:
  virtual ~ForceLoop() = default;
  /// One force-loop tick at `now` (s, monotonic, the loop's own clock). Called
  /// from the servo thread: allocates nothing, takes no lock, does no I/O.
  virtual void force_tick(double now) noexcept = 0;
};

}  // namespace organsim::devices

// How long this machine takes the processor away from a real-time thread that
// never blocks. A SCHED_FIFO thread (priority 99, memory locked) spins reading
// the monotonic clock for 0.8 ms (or as given) of every millisecond (staying under the
// kernel's 95 % real-time throttle) and records each gap between two
// consecutive readings. Inside such a spin only interrupt handlers
// (microseconds) and the hypervisor or firmware can take the CPU, so gaps of a
// millisecond or more are the machine's, not any program's: no force loop can
// keep a 2 ms deadline through them. It also records how late the thread
// wakes from the sleep between windows: a sleeping virtual CPU may be
// descheduled by its host and woken late.
//   build/tests/cpu_stalls [seconds] [spin per millisecond, ms: 0.8]
#include <sys/mman.h>

#include <cstdio>
#include <cstdlib>
#include <stdexcept>

#include "organsim/realtime/cpu_stalls.h"

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 60.0;
  const double spin_ms = argc > 2 ? std::atof(argv[2]) : 0.8;
  const bool locked = mlockall(MCL_CURRENT | MCL_FUTURE) == 0;
  organsim::realtime::CpuStalls s;
  try {
    s = organsim::realtime::measure_cpu_stalls(seconds, spin_ms * 1e-3);
  } catch (const std::invalid_argument& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  }
  if (!s.realtime_priority) std::printf("warning: no real-time priority (SCHED_FIFO); gaps include other programs\n");
  std::printf(
      "%.0f s of %.2f ms spinning windows (%s%s): gaps > 0.1 ms %lld, > 1 ms %lld, > 2 ms %lld; largest %.3f ms\n",
      seconds, spin_ms, s.realtime_priority ? "SCHED_FIFO 99" : "normal priority", locked ? ", memory locked" : "",
      s.gaps_over_100us, s.gaps_over_1ms, s.gaps_over_2ms, s.largest_gap * 1e3);
  std::printf(
      "wake-ups from the sleeps between windows: later than 0.3 ms %lld, 1 ms %lld, 2 ms %lld; latest %.3f ms\n",
      s.late_over_300us, s.late_over_1ms, s.late_over_2ms, s.latest_wake * 1e3);
  return 0;
}

// How long this machine takes the processor away from a real-time thread that
// never blocks: the floor against which a loop's missed deadlines are judged
// (docs/realtime.md). The calling thread, at SCHED_FIFO priority 99 where the
// OS permits (its own policy is restored afterwards), spins reading the
// monotonic clock for `spin` of every millisecond (staying under the kernel's
// 95 % real-time throttle) and records each gap between two consecutive
// readings. Inside such a spin only interrupt handlers (microseconds) and the
// hypervisor or firmware can take the CPU, so gaps of a millisecond or more
// are the machine's, not any program's. It also records how late the thread
// wakes from the sleep between windows.
#pragma once

namespace organsim::realtime {

struct CpuStalls {
  double seconds = 0.0;            ///< spinning windows measured for
  bool realtime_priority = false;  ///< false: the gaps include other programs
  long long gaps_over_100us = 0, gaps_over_1ms = 0, gaps_over_2ms = 0;
  double largest_gap = 0.0;                                             ///< s
  long long late_over_300us = 0, late_over_1ms = 0, late_over_2ms = 0;  ///< wake-ups after the sleeps
  double latest_wake = 0.0;                                             ///< s
};

/// Measures for `seconds` with windows spinning `spin` s of every millisecond
/// (0 < spin ≤ 0.9e-3; throws std::invalid_argument otherwise).
CpuStalls measure_cpu_stalls(double seconds, double spin = 0.8e-3);

}  // namespace organsim::realtime

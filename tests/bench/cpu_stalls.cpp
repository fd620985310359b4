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
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <time.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace {

long long now_ns() {
  timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<long long>(t.tv_sec) * 1000000000LL + t.tv_nsec;
}

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 60.0;
  const bool locked = mlockall(MCL_CURRENT | MCL_FUTURE) == 0;
  sched_param parameter{};
  parameter.sched_priority = 99;
  const int error = pthread_setschedparam(pthread_self(), SCHED_FIFO, &parameter);
  if (error != 0)
    std::printf("warning: no real-time priority (SCHED_FIFO: %s); gaps include other programs\n", std::strerror(error));

  constexpr long long kPeriod = 1000000;  // ns
  const double spin_ms = argc > 2 ? std::atof(argv[2]) : 0.8;
  if (!(spin_ms > 0.0 && spin_ms <= 0.9)) {
    std::fprintf(stderr, "spin per millisecond: more than 0 and at most 0.9 ms (the real-time throttle)\n");
    return 2;
  }
  const auto kSpin = static_cast<long long>(spin_ms * 1e6);
  const long long windows = static_cast<long long>(seconds * 1e9 / kPeriod);
  long long over_100us = 0, over_1ms = 0, over_2ms = 0, largest = 0;
  long long late_300us = 0, late_1ms = 0, late_2ms = 0, latest = 0;  // wake-ups after the sleeps
  long long next = now_ns() + kPeriod;
  for (long long w = 0; w < windows; ++w) {
    const long long begin = now_ns();
    long long previous = begin;
    while (previous - begin < kSpin) {
      const long long t = now_ns();
      const long long gap = t - previous;
      if (gap > 100000) {
        ++over_100us;
        over_1ms += gap > 1000000;
        over_2ms += gap > 2000000;
        largest = std::max(largest, gap);
      }
      previous = t;
    }
    const timespec wake{static_cast<time_t>(next / 1000000000LL), static_cast<long>(next % 1000000000LL)};
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &wake, nullptr);
    const long long late = now_ns() - next;
    late_300us += late > 300000;
    late_1ms += late > 1000000;
    late_2ms += late > 2000000;
    latest = std::max(latest, late);
    next = std::max(next + kPeriod, now_ns());
  }
  std::printf("%.0f s of %.2f ms spinning windows (%s%s): gaps > 0.1 ms %lld, > 1 ms %lld, > 2 ms %lld; largest %.3f ms\n",
              seconds, spin_ms, error == 0 ? "SCHED_FIFO 99" : "normal priority", locked ? ", memory locked" : "", over_100us,
              over_1ms, over_2ms, largest * 1e-6);
  std::printf("wake-ups from the sleeps between windows: later than 0.3 ms %lld, 1 ms %lld, 2 ms %lld; latest %.3f ms\n",
              late_300us, late_1ms, late_2ms, latest * 1e-6);
  return 0;
}

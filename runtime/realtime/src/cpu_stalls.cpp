#include "organsim/realtime/cpu_stalls.h"

#include <pthread.h>
#include <sched.h>
#include <time.h>

#include <algorithm>
#include <stdexcept>

namespace organsim::realtime {
namespace {

long long now_ns() {
  timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<long long>(t.tv_sec) * 1000000000LL + t.tv_nsec;
}

}  // namespace

CpuStalls measure_cpu_stalls(double seconds, double spin) {
  if (!(spin > 0.0 && spin <= 0.9e-3))
    throw std::invalid_argument(
        "the spin per millisecond must be more than 0 and at most 0.9 ms (the real-time throttle)");
  int policy = 0;
  sched_param previous{};
  pthread_getschedparam(pthread_self(), &policy, &previous);
  sched_param parameter{};
  parameter.sched_priority = 99;
  CpuStalls s;
  s.seconds = seconds;
  s.realtime_priority = pthread_setschedparam(pthread_self(), SCHED_FIFO, &parameter) == 0;

  constexpr long long kPeriod = 1000000;  // ns
  const auto spin_ns = static_cast<long long>(spin * 1e9);
  const auto windows = static_cast<long long>(seconds * 1e9 / kPeriod);
  long long largest = 0, latest = 0;
  long long next = now_ns() + kPeriod;
  for (long long w = 0; w < windows; ++w) {
    const long long begin = now_ns();
    long long previous_reading = begin;
    while (previous_reading - begin < spin_ns) {
      const long long t = now_ns();
      const long long gap = t - previous_reading;
      if (gap > 100000) {
        ++s.gaps_over_100us;
        s.gaps_over_1ms += gap > 1000000;
        s.gaps_over_2ms += gap > 2000000;
        largest = std::max(largest, gap);
      }
      previous_reading = t;
    }
    const timespec wake{static_cast<time_t>(next / 1000000000LL), static_cast<long>(next % 1000000000LL)};
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &wake, nullptr);
    const long long late = now_ns() - next;
    s.late_over_300us += late > 300000;
    s.late_over_1ms += late > 1000000;
    s.late_over_2ms += late > 2000000;
    latest = std::max(latest, late);
    next = std::max(next + kPeriod, now_ns());
  }
  pthread_setschedparam(pthread_self(), policy, &previous);
  s.largest_gap = static_cast<double>(largest) * 1e-9;
  s.latest_wake = static_cast<double>(latest) * 1e-9;
  return s;
}

}  // namespace organsim::realtime

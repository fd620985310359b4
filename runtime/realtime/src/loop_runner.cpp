#include "organsim/realtime/loop_runner.h"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <time.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <exception>
#include <thread>

namespace organsim::realtime {
namespace {

// s: wake this early and spin to the deadline. A sleeping (virtual) CPU wakes
// late now and then, by milliseconds on a VM whose host deschedules it; the
// short sleep left (0.1 ms of 1 ms) keeps the thread under the kernel's 95 %
// real-time throttle and lets the CPU's kernel threads run (docs/realtime.md).
constexpr double kSpinAhead = 9e-4;
// s: PollOptions::around_force_ticks polls this long before a force tick (a
// woken thread may start 0.05 ms late on a VM) and this long after it.
constexpr double kPollBeforeTick = 1e-4, kPollAfterTick = 5e-5;

double seconds(const timespec& t) { return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec); }

timespec now_monotonic() {
  timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t;
}

void advance(timespec& t, double period) {
  const auto step = static_cast<long long>(std::llround(period * 1e9));
  long long nanoseconds = static_cast<long long>(t.tv_sec) * 1000000000LL + t.tv_nsec + step;
  t.tv_sec = static_cast<time_t>(nanoseconds / 1000000000LL);
  t.tv_nsec = static_cast<long>(nanoseconds % 1000000000LL);
}

std::size_t ticks_for(double duration, double period) {
  return static_cast<std::size_t>(std::floor(duration / period + 1e-9)) + 1;
}

// Runs `body(time)` every `period` until `count` ticks have come due or `stop`
// is set, sleeping to absolute deadlines so that lateness does not accumulate.
// With `skipped`, ticks whose time passed while the body ran are skipped and
// counted there (a deformation model slower than its frame rate drops frames,
// as a display does, instead of running behind the session for ever);
// otherwise each tick runs, late ones back to back. `timed(seconds)` gets
// each body's compute time after it is recorded.
template <typename Body, typename Timed>
void periodic(double period, std::size_t count, const timespec& start, DurationHistogram& periods,
              DurationHistogram& computes, std::atomic<bool>& stop, std::uint64_t* skipped, Body body, Timed timed) {
  timespec next = start;
  double previous = -1.0;
  for (std::size_t k = 0; k < count && !stop.load(std::memory_order_relaxed); ++k) {
    timespec early = next;
    advance(early, -kSpinAhead);
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &early, nullptr);
    while (seconds(now_monotonic()) < seconds(next)) {
    }
    const timespec begin = now_monotonic();
    const double time = seconds(begin) - seconds(start);
    body(time);
    const timespec end = now_monotonic();
    if (previous >= 0.0) periods.record(time - previous);
    computes.record(seconds(end) - seconds(begin));
    timed(seconds(end) - seconds(begin));
    previous = time;
    advance(next, period);
    if (skipped)
      while (k + 1 < count && seconds(next) < seconds(end)) {
        advance(next, period);
        ++k;
        ++*skipped;
      }
  }
}

}  // namespace

Percentiles percentiles(std::vector<double> samples) {
  Percentiles p;
  if (samples.empty()) return p;
  std::sort(samples.begin(), samples.end());
  auto at = [&](double q) {
    const auto index = static_cast<std::size_t>(std::ceil(q * static_cast<double>(samples.size()))) - 1;
    return samples[std::min(samples.size() - 1, index)];
  };
  p.p50 = at(0.50);
  p.p99 = at(0.99);
  p.max = samples.back();
  return p;
}

RunTimings run_fast(Engine& engine, double duration, const std::function<void(const RunTimings&)>& after_frame) {
  RunTimings timings;
  engine.set_reproducible(true);
  const EngineOptions& o = engine.options();
  const std::size_t ticks = ticks_for(duration, o.force_period);
  const auto wall_start = std::chrono::steady_clock::now();
  std::size_t next_frame = 0;  // index of the next deformation frame
  for (std::size_t k = 0; k < ticks; ++k) {
    // Session time from integers, so every run steps the same times.
    const double time = static_cast<double>(k) * o.force_period;
    if (time + 1e-12 >= static_cast<double>(next_frame) * o.deformation_period) {
      const auto begin = std::chrono::steady_clock::now();
      engine.deformation_step(time);
      const double compute = std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
      timings.deformation_computes.record(compute);
      if (engine.touched_in_last_step()) timings.contact_computes.record(compute);
      ++next_frame;
      if (after_frame) after_frame(timings);
    }
    const auto begin = std::chrono::steady_clock::now();
    engine.force_tick(time);
    timings.force_computes.record(std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count());
  }
  timings.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return timings;
}

RunTimings run_realtime(Engine& engine, double duration, const std::function<bool(const RunTimings&)>& poll,
                        const PollOptions& polling) {
  RunTimings timings;
  engine.set_reproducible(false);  // a frame never waits for the FEM tangent worker
  const EngineOptions& o = engine.options();
  const std::size_t force_ticks = ticks_for(duration, o.force_period);
  const std::size_t frames = ticks_for(duration, o.deformation_period);
  // Keep every page resident: a page fault in the force loop costs a deadline.
  const bool locked = mlockall(MCL_CURRENT | MCL_FUTURE) == 0;

  std::atomic<bool> stop{false}, force_done{false}, deformation_done{false};
  std::atomic<int> priority_error{0}, deformation_priority_error{0};
  timespec start = now_monotonic();
  advance(start, 0.01);  // both loops start together, after the threads exist
  const auto wall_start = std::chrono::steady_clock::now();

  std::thread force([&] {
    sched_param parameter{};
    parameter.sched_priority = 80;
    priority_error.store(pthread_setschedparam(pthread_self(), SCHED_FIFO, &parameter));
    periodic(
        o.force_period, force_ticks, start, timings.force_periods, timings.force_computes, stop, nullptr,
        [&](double time) { engine.force_tick(time); }, [](double) {});
    force_done.store(true);
  });
  std::thread deformation([&] {
    // Real-time too, below the force loop: the scheduler then keeps the two
    // loops on different CPUs. As an ordinary thread the deformation loop was
    // now and then placed on the force loop's CPU, where the spinning force
    // thread leaves it 10 % of the time (co-rotational liver frames of 5 ms
    // took 60 ms), and it competed with model workers for the other one.
    sched_param parameter{};
    parameter.sched_priority = 70;
    deformation_priority_error.store(pthread_setschedparam(pthread_self(), SCHED_FIFO, &parameter));
    periodic(
        o.deformation_period, frames, start, timings.deformation_periods, timings.deformation_computes, stop,
        &timings.deformation_frames_dropped, [&](double time) { engine.deformation_step(time); },
        [&](double compute) {
          if (engine.touched_in_last_step()) timings.contact_computes.record(compute);
        });
    deformation_done.store(true);
  });
  int poll_policy = SCHED_OTHER, poll_priority_error = 0;
  sched_param poll_parameter{};
  if (polling.priority > 0) {
    pthread_getschedparam(pthread_self(), &poll_policy, &poll_parameter);
    sched_param raised{};
    raised.sched_priority = polling.priority;
    poll_priority_error = pthread_setschedparam(pthread_self(), SCHED_FIFO, &raised);
  }
  // Around force ticks: poll j at tick j/2 + kPollAfterTick (j even), or at
  // tick (j + 1)/2 − kPollBeforeTick (j odd).
  // In whole nanoseconds per tick, as the force loop advances its deadlines.
  std::size_t tick_poll = 0;
  auto next_tick_poll = [&] {
    const long long tick = std::llround(o.force_period * 1e9);
    const long long after_start =
        tick_poll % 2 == 0 ? static_cast<long long>(tick_poll / 2) * tick + std::llround(kPollAfterTick * 1e9)
                           : static_cast<long long>((tick_poll + 1) / 2) * tick - std::llround(kPollBeforeTick * 1e9);
    timespec at = start;
    advance(at, 1e-9 * static_cast<double>(after_start));
    return at;
  };
  std::exception_ptr failure;
  bool kept_missed_poll = false;
  while (!force_done.load() || !deformation_done.load()) {
    try {
      if (poll && !failure && !poll(timings)) stop.store(true);
    } catch (...) {  // stop and join the loops before reporting it
      failure = std::current_exception();
      stop.store(true);
    }
    if (!polling.around_force_ticks) {
      std::this_thread::sleep_for(std::chrono::duration<double>(polling.period));
      continue;
    }
    // A poll time that passed while this poll ran (a frame's surface, a
    // late wake) is kept at once, not skipped: after a tick, its forces
    // leave now rather than a tick later. Once only: polls that keep running
    // late then sleep to the next time ahead, so that the thread never holds
    // its CPU from the deformation loop. The times missed beyond it are skipped.
    const double now = seconds(now_monotonic());
    timespec at = next_tick_poll();
    bool missed = false;
    while (seconds(at) <= now) {
      ++tick_poll;
      at = next_tick_poll();
      missed = true;
    }
    if (missed && !kept_missed_poll) {
      kept_missed_poll = true;
      continue;
    }
    kept_missed_poll = false;
    ++tick_poll;
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &at, nullptr);
  }
  force.join();
  deformation.join();
  if (polling.priority > 0 && poll_priority_error == 0)
    pthread_setschedparam(pthread_self(), poll_policy, &poll_parameter);
  if (locked) munlockall();
  if (failure) std::rethrow_exception(failure);
  if (poll) poll(timings);
  timings.wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  const int error = priority_error.load() != 0 ? priority_error.load() : deformation_priority_error.load();
  timings.realtime_priority = error == 0 && poll_priority_error == 0;
  if (error != 0 || poll_priority_error != 0)
    timings.priority_warning =
        std::string(error != 0 ? "the loops run" : "the polling thread runs") +
        " without real-time priority (SCHED_FIFO: " + std::strerror(error != 0 ? error : poll_priority_error) +
        "); run as root or grant CAP_SYS_NICE for steadier timing";
  timings.force_deadline_misses = timings.force_periods.above_threshold();
  return timings;
}

}  // namespace organsim::realtime

// Running the engine's two loops: in real time on their own threads, or
// stepped deterministically as fast as possible (bit-identical forces on every
// run of the same build). Both record loop timings into preallocated arrays.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "organsim/realtime/engine.h"

namespace organsim::realtime {

struct Percentiles {
  double p50 = 0.0, p99 = 0.0, max = 0.0;  ///< s
};
/// Percentiles of samples (s); zeros when there are none.
Percentiles percentiles(std::vector<double> samples);

struct RunTimings {
  std::vector<double> force_periods;         ///< s between successive force ticks (real time only)
  std::vector<double> force_computes;        ///< s inside force_tick
  std::vector<double> deformation_periods;   ///< s between successive deformation steps (real time only)
  std::vector<double> deformation_computes;  ///< s inside deformation_step
  std::uint64_t force_deadline_misses = 0;   ///< force periods longer than 2 ms
  bool realtime_priority = false;            ///< both loops got SCHED_FIFO (force 80, deformation 70)
  std::string priority_warning;              ///< why not, when it did not
  double wall_seconds = 0.0;
};

/// Steps the loops deterministically for `duration` (s) of session time: force
/// ticks every force_period, a deformation step whenever session time reaches
/// the next deformation_period boundary (before that tick). `after_frame` (may
/// be empty) runs after each deformation step, outside the loops' timing.
RunTimings run_fast(Engine& engine, double duration, const std::function<void()>& after_frame = {});

/// Runs the loops on two threads at their rates for `duration` (s) of wall
/// time, with real-time priority where the OS permits (the force thread above
/// the deformation thread).
/// `poll` (may be empty) runs repeatedly on the calling thread meanwhile (for
/// example to save or draw published frames; returning false stops the loops
/// early), and once more after the loops stop.
RunTimings run_realtime(Engine& engine, double duration, const std::function<bool()>& poll = {});

}  // namespace organsim::realtime

// Running the engine's two loops: in real time on their own threads, or
// stepped deterministically as fast as possible (bit-identical forces on every
// run of the same build). Both record loop timings into fixed-size histograms,
// so that a run of any length uses the same memory.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "organsim/realtime/duration_histogram.h"
#include "organsim/realtime/engine.h"

namespace organsim::realtime {

/// Exact percentiles of samples (s); zeros when there are none.
Percentiles percentiles(std::vector<double> samples);

/// A force period longer than this is a deadline miss (s).
inline constexpr double kForceDeadline = 2e-3;

struct RunTimings {
  DurationHistogram force_periods{kForceDeadline};  ///< s between successive force ticks (real time only)
  DurationHistogram force_computes;                 ///< s inside force_tick
  DurationHistogram deformation_periods;            ///< s between successive deformation steps (real time only)
  DurationHistogram deformation_computes;           ///< s inside deformation_step
  /// The same for the steps in which a tool held the organ: a session's
  /// frames with no tool on it (for the FEM models the rest state, nothing to
  /// solve) would otherwise make the median of a model that drops its
  /// contact frames.
  DurationHistogram contact_computes;
  std::uint64_t force_deadline_misses = 0;       ///< force periods longer than kForceDeadline
  std::uint64_t deformation_frames_dropped = 0;  ///< frames whose time passed while the one before ran (real time)
  bool realtime_priority = false;  ///< both loops got SCHED_FIFO (force 80, deformation 70), and the polling thread its
                                   ///< PollOptions::priority
  std::string priority_warning;    ///< why not, when it did not
  double wall_seconds = 0.0;
};

/// Steps the loops deterministically for `duration` (s) of session time: force
/// ticks every force_period, a deformation step whenever session time reaches
/// the next deformation_period boundary (before that tick). `after_frame` (may
/// be empty) runs after each deformation step, outside the loops' timing, with
/// the timings so far.
RunTimings run_fast(Engine& engine, double duration, const std::function<void(const RunTimings&)>& after_frame = {});

/// How run_realtime's calling thread polls while the loops run.
struct PollOptions {
  double period = 2e-3;  ///< s between polls, at most
  /// Poll just before each force tick and just after it instead (period
  /// unused): what arrived since the last poll reaches the tick, and what the
  /// tick computed leaves at once (a network service's pose in → force out).
  bool around_force_ticks = false;
  /// > 0: the calling thread polls at this SCHED_FIFO priority while the loops
  /// run, and gets its own scheduling back after: for a network service whose
  /// latency is the poll's (above the deformation loop's 70, so that a frame
  /// does not hold a pose or a force back; its work per poll must be short).
  int priority = 0;
};

/// Runs the loops on two threads at their rates for `duration` (s) of wall
/// time, with real-time priority where the OS permits (the force thread above
/// the deformation thread). A deformation model slower than the frame rate
/// drops the frames whose time passed while it worked; the force loop runs
/// every tick.
/// `poll` (may be empty) runs every `polling.period` s on the calling thread
/// meanwhile (for example to save published frames and recorded forces, to
/// send forces to network clients, or to report the timings so far, which it
/// receives; returning false stops the loops early), and once more after the
/// loops stop.
RunTimings run_realtime(Engine& engine, double duration, const std::function<bool(const RunTimings&)>& poll = {},
                        const PollOptions& polling = {});

}  // namespace organsim::realtime

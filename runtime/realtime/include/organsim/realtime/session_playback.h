// A recorded session (devices/session_file.h) played through the engine: one
// scripted device per tool, the engine on them, and the loops run fast
// (deterministic, session time) or in real time. What `organsim replay`,
// `organsim view --session` and the Python module's replay() share.
//
// The devices record every force the force loop wrote (take_record() or
// record()); they and the engine live as long as the playback. Construction
// allocates and may throw (the engine's and the model's); the runs follow
// loop_runner.h.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <vector>

#include "organsim/devices/scripted_device.h"
#include "organsim/devices/session_file.h"
#include "organsim/organ/organ.h"
#include "organsim/realtime/engine.h"
#include "organsim/realtime/loop_runner.h"

namespace organsim::realtime {

struct PlaybackOptions {
  devices::SafetyLimits limits;  ///< each scripted device's (the force clamp the engine applies)
  /// Force records each device holds before the oldest is dropped: enough for
  /// what accumulates between two takes, or the whole session's ticks when
  /// nobody takes them during the run (records_for_whole_session).
  std::size_t records_per_tool = 8192;
  /// > 0: the trajectories start over every repeat_period s (`replay --repeat-for`).
  double repeat_period = 0.0;
};

/// Records a device needs to keep every force tick of `duration` s at
/// `force_period` s, with a margin.
std::size_t records_for_whole_session(double duration, double force_period) noexcept;

/// `options` with the tip radius the session gives for each of its tools (its
/// tip lines): that tool's; the others keep options.tip_radius. What the
/// playback's engine runs with (EngineOptions::tip_radius_of reads them).
EngineOptions with_session_tips(const EngineOptions& options, const devices::Session& session);

class SessionPlayback {
 public:
  SessionPlayback(const organ::Organ& organ, const devices::Session& session, const EngineOptions& engine_options,
                  const PlaybackOptions& options = {});
  SessionPlayback(const SessionPlayback&) = delete;  // the engine points at the devices
  SessionPlayback& operator=(const SessionPlayback&) = delete;

  Engine& engine() noexcept { return *engine_; }
  const Engine& engine() const noexcept { return *engine_; }
  /// One per session tool, in the session's tool order.
  const std::vector<std::unique_ptr<devices::ScriptedDevice>>& devices() const noexcept { return devices_; }

  /// run_fast(engine(), duration, after_frame).
  RunTimings run_fast(double duration, const std::function<void(const RunTimings&)>& after_frame = {});
  /// run_realtime(engine(), duration, poll).
  RunTimings run_realtime(double duration, const std::function<bool(const RunTimings&)>& poll = {});

 private:
  std::vector<std::unique_ptr<devices::ScriptedDevice>> devices_;  // before engine_: it points at them
  std::unique_ptr<Engine> engine_;
};

}  // namespace organsim::realtime

#include "organsim/realtime/session_playback.h"

#include <cmath>

namespace organsim::realtime {
namespace {

std::vector<devices::HapticDevice*> pointers(const std::vector<std::unique_ptr<devices::ScriptedDevice>>& devices) {
  std::vector<devices::HapticDevice*> out;
  out.reserve(devices.size());
  for (const auto& device : devices) out.push_back(device.get());
  return out;
}

}  // namespace

std::size_t records_for_whole_session(double duration, double force_period) noexcept {
  return static_cast<std::size_t>(std::ceil(duration / force_period)) + 16;
}

EngineOptions with_session_tips(const EngineOptions& options, const devices::Session& session) {
  EngineOptions with_tips = options;
  for (std::size_t k = 0; k < session.tools.size(); ++k)
    if (session.tools[k].tip_radius >= 0.0) {
      with_tips.tool_tip_radii.resize(session.tools.size(), -1.0);
      with_tips.tool_tip_radii[k] = session.tools[k].tip_radius;
    }
  return with_tips;
}

SessionPlayback::SessionPlayback(const organ::Organ& organ, const devices::Session& session,
                                 const EngineOptions& engine_options, const PlaybackOptions& options) {
  devices_.reserve(session.tools.size());
  for (const devices::Trajectory& trajectory : session.tools)
    devices_.push_back(std::make_unique<devices::ScriptedDevice>(trajectory, options.limits, options.records_per_tool,
                                                                 options.repeat_period));
  engine_ = std::make_unique<Engine>(organ, pointers(devices_), with_session_tips(engine_options, session));
}

RunTimings SessionPlayback::run_fast(double duration, const std::function<void(const RunTimings&)>& after_frame) {
  return realtime::run_fast(*engine_, duration, after_frame);
}

RunTimings SessionPlayback::run_realtime(double duration, const std::function<bool(const RunTimings&)>& poll) {
  return realtime::run_realtime(*engine_, duration, poll);
}

}  // namespace organsim::realtime

// Fuzz target for the session-file reader (`organsim replay`, `view
// --session`). Every input must either be refused with one line that starts
// with the file's name, or give a session that keeps the reader's promises
// (1 to 16 tools, each with samples at increasing finite times within a day,
// finite positions within 10 m of the organ, unit shafts or none), which a
// scripted device then plays without a non-finite pose.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <sstream>
#include <stdexcept>
#include <string>

#include "organsim/devices/scripted_device.h"
#include "organsim/devices/session_file.h"

namespace {

using namespace organsim::devices;

void check(const Session& session, const SessionLimits& limits) {
  if (session.tools.empty() || session.tools.size() > 16) std::abort();
  if (!(session.duration >= 0.0 && session.duration <= limits.max_duration)) std::abort();
  for (const Trajectory& t : session.tools) {
    if (t.times.empty() || t.positions.size() != t.times.size()) std::abort();
    if (!t.shafts.empty() && t.shafts.size() != t.times.size()) std::abort();
    for (std::size_t i = 0; i < t.times.size(); ++i) {
      if (!std::isfinite(t.times[i]) || t.times[i] < 0.0 || t.times[i] > session.duration) std::abort();
      if (i > 0 && !(t.times[i] > t.times[i - 1])) std::abort();
      if (!t.positions[i].allFinite() ||
          limits.organ_box.exteriorDistance(t.positions[i]) > limits.max_distance * 1.000001)
        std::abort();
      if (!t.shafts.empty() && std::abs(t.shafts[i].norm() - 1.0) > 1e-9) std::abort();
    }
    ScriptedDevice device(t, {}, 4, session.duration);
    ToolPose pose;
    for (const double time : {0.0, 0.5 * session.duration, session.duration, 2.5 * session.duration + 0.1})
      if (!device.read_pose(time, pose) || !pose.tip.allFinite() || !pose.shaft.allFinite()) std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  SessionLimits limits;
  limits.organ_box = Eigen::AlignedBox3d(Eigen::Vector3d(-0.1, -0.1, -0.1), Eigen::Vector3d(0.1, 0.1, 0.1));
  std::istringstream in(text);
  try {
    check(parse_session(in, "fuzz.session", limits), limits);
  } catch (const std::runtime_error& error) {
    const std::string message = error.what();
    if (message.rfind("fuzz.session", 0) != 0 || message.find('\n') != std::string::npos) std::abort();
  }
  return 0;
}

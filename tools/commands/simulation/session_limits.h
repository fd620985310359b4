// The limits `replay` and `view --session` read session files with.
#pragma once

#include <limits>

#include "organsim/devices/session_file.h"
#include "organsim/model/organ_model.h"

namespace organsim::cli {

/// Tools within 10 m of the model's surface; sessions of a day at most unless
/// `long_session` (--long-session).
inline devices::SessionLimits session_limits(const model::OrganModel& model, bool long_session) {
  devices::SessionLimits limits;
  if (long_session) limits.max_duration = std::numeric_limits<double>::infinity();
  for (const model::Point3& p : model.surface_vertices) limits.organ_box.extend(Eigen::Vector3d(p[0], p[1], p[2]));
  return limits;
}

}  // namespace organsim::cli

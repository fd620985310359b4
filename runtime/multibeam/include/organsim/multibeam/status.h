// Outcome of the real-time multi-beam calls: a plain value, never an exception,
// with a fixed English sentence for each (no allocation to describe it).
#pragma once

#include <cstdint>

namespace organsim::multibeam {

enum class Status : std::uint8_t {
  ok = 0,
  not_finite,        ///< an input point or displacement holds NaN or Inf
  far_from_organ,    ///< the tool point is farther from the surface than the snap distance
  at_fixed_point,    ///< the action point is (nearly) at the clamp: no beam can be built
  no_beam_tables,    ///< the model has no beam tables (bake it with stations > 0)
  singular_beam,     ///< the beam's stiffness matrix is not positive definite
  too_many_tools,    ///< more tools than the state was sized for
  no_contact,        ///< the tool has no beam (no contact set)
  buffer_too_small,  ///< a caller buffer is smaller than the organ
};

/// One sentence saying what went wrong and what to do; static storage.
const char* describe(Status status) noexcept;

}  // namespace organsim::multibeam

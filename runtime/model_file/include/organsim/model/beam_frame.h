// The local frame of a beam, shared by the pipeline (which bakes section
// properties in it) and the runtime (which builds beam elements in it).
#pragma once

#include <array>

namespace organsim::model {

/// Right-handed orthonormal frame of a beam from point `from` to point `to`.
struct BeamFrame {
  std::array<double, 3> x;  ///< unit beam axis, from `from` to `to`
  std::array<double, 3> y;  ///< unit, perpendicular to x
  std::array<double, 3> z;  ///< x × y
};

/// Deterministic frame convention: x = (to − from)/|to − from|; y is the world
/// axis (X, Y or Z, the first one on ties) least aligned with x, made
/// perpendicular to x and normalized; z = x × y. Returns false (and leaves
/// `frame` untouched) when |to − from| is zero or not finite.
bool make_beam_frame(const std::array<double, 3>& from, const std::array<double, 3>& to, BeamFrame& frame) noexcept;

}  // namespace organsim::model

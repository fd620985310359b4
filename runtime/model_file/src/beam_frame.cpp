#include "organsim/model/beam_frame.h"

#include <cmath>

namespace organsim::model {

bool make_beam_frame(const std::array<double, 3>& from, const std::array<double, 3>& to, BeamFrame& frame) noexcept {
  std::array<double, 3> x{to[0] - from[0], to[1] - from[1], to[2] - from[2]};
  const double length = std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
  if (!(length > 0.0) || !std::isfinite(length)) return false;
  for (double& c : x) c /= length;

  // The world axis least aligned with x keeps y well conditioned.
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (std::abs(x[k]) < std::abs(x[axis])) axis = k;
  std::array<double, 3> y{0.0, 0.0, 0.0};
  y[axis] = 1.0;
  const double along = y[0] * x[0] + y[1] * x[1] + y[2] * x[2];
  for (int k = 0; k < 3; ++k) y[k] -= along * x[k];
  const double y_length = std::sqrt(y[0] * y[0] + y[1] * y[1] + y[2] * y[2]);
  for (double& c : y) c /= y_length;

  frame.x = x;
  frame.y = y;
  frame.z = {x[1] * y[2] - x[2] * y[1], x[2] * y[0] - x[0] * y[2], x[0] * y[1] - x[1] * y[0]};
  return true;
}

}  // namespace organsim::model

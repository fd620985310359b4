// `organsim calibrate --pull`'s pull curve (docs/matching.md#pulls): how much
// softer the patch a grasper holds is than the bonded punch the site law
// starts from, as the jaws draw it out. At sites spread over the organ (other
// than those `calibrate --evaluate` pulls), each grasped after a bite and
// drawn out straight along the normal and tilted 45° by each distance, the FEM
// reference holds the tip's footprint on the organ re-meshed finely there;
// for each pull the softening s is the one whose held-patch law,
// F = F(d_g) − (C_organ + s C_punch)⁻¹ (d − d_g), gives the reference's
// |F|. The curve's point at each distance is the pulls' geometric mean, after
// (0, 1): a patch barely drawn is the linear bonded punch.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "organsim/model/organ_model.h"
#include "press_plan.h"

namespace organsim::cli {

struct PullCurveOptions : CurveSiteOptions {
  std::vector<double> distances_mm{5.0, 10.0, 20.0};  ///< how far each grasp is drawn out
  double bite_mm = 2.0;                               ///< how deep the jaws bite before they close
};

struct PullCurveFit {
  /// (u m, softening s): (0, 1), then per distance the pulls' mean distance
  /// since the jaws closed and their geometric-mean softening.
  std::vector<std::array<double, 2>> curve;
  std::size_t pulls = 0, solved = 0;
  double refine_size_mm = 0.0;  ///< as used
  /// Per curve point after the first: how far the pulls' softenings scatter
  /// about it, exp(√mean ln²(s / s̄)).
  std::vector<double> scatter;
  /// Per curve point after the first: the factor the law's forces are then
  /// typically off the reference's by, exp(√mean ln²(|F| / |F_ref|)).
  std::vector<double> force_factor;
};

/// The pull curve of `model` (which has site compliances) for the tip of
/// `o.press.tuning.tip_radius`. Throws std::runtime_error when no pull solves.
PullCurveFit fit_pull_curve(const model::OrganModel& model, const PullCurveOptions& o);

}  // namespace organsim::cli

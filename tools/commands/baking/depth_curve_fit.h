// `organsim calibrate`'s depth curve (docs/matching.md): how much the FEM
// reference's force at depth d exceeds the site law's linear one, −K d, for a
// tool of the calibrated radius, both pressed by the same contact rule (the
// organ slipping under the tool outside the friction cone). Measured with the reference pressed on the
// organ re-meshed finely around each press (as `calibrate --evaluate` does),
// at sites spread over the organ, straight in and tilted 45°; the curve's
// factor at each depth is the geometric mean of the presses' ratios
// |F_ref| / |F_law| (what minimizes the typical factor off, as for the
// stiffness scales).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "organsim/model/organ_model.h"
#include "press_plan.h"

namespace organsim::cli {

struct DepthCurveOptions : CurveSiteOptions {
  std::vector<double> depths_mm{2.0, 5.0, 10.0};  ///< the curve's depths
};

struct DepthCurveFit {
  std::vector<std::array<double, 2>> curve;  ///< (depth m, factor): depths where a press solved
  std::size_t presses = 0, solved = 0;
  double refine_size_mm = 0.0;  ///< as used
  /// Per curve depth: how far the presses scatter about the factor,
  /// exp(√mean ln²(ratio / factor)) (1: the linear law's site-to-site shape is the reference's).
  std::vector<double> scatter;
};

/// The depth curve of `model` (which has site compliances) for the tip of
/// `o.press.tuning.tip_radius`. Throws std::runtime_error when no press solves.
DepthCurveFit fit_depth_curve(const model::OrganModel& model, const DepthCurveOptions& o);

}  // namespace organsim::cli

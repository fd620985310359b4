// Stage 2b of the pipeline: the fixed point, where every beam of the
// multi-beam model is clamped (e.g. the portal vein entry of a liver). Given by
// the user as a physical point or a voxel, checked to lie in or on the organ;
// by default the organ's deepest interior point.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <utility>

#include "organsim/pipeline/ct_image.h"

namespace organsim::pipeline {

/// How far (mm) outside the mask a given fixed point may lie: a vessel entry is
/// excluded from an organ mask, so the point may sit a little way outside it.
inline constexpr double kFixedPointToleranceMm = 10.0;

struct FixedPoint {
  std::array<double, 3> point_mm{};  ///< physical point, LPS, mm
  std::string source;                ///< "given point", "given voxel" or "deepest interior point"
  double depth_mm = 0.0;             ///< deepest interior point: its distance to the mask boundary
  double outside_mm = 0.0;           ///< given point or voxel: distance to the nearest organ voxel centre
};

/// The fixed point: `point_mm` or `voxel` when given (at most one), otherwise
/// the deepest interior point. Throws std::runtime_error with one line when a
/// given voxel lies outside the image or a given point more than
/// kFixedPointToleranceMm outside the organ.
FixedPoint choose_fixed_point(const MaskImage& mask, const std::optional<std::array<double, 3>>& point_mm,
                              const std::optional<std::array<long, 3>>& voxel);

/// The deepest interior voxel of a mask (largest distance to the boundary;
/// the first in memory order on ties) as a physical point (mm), with its depth (mm).
std::pair<std::array<double, 3>, double> deepest_interior_point(const MaskImage& mask);

/// Distance (mm) from `point_mm` to the nearest organ voxel centre (inside the
/// organ: at most half a voxel diagonal); any value above `limit_mm` means
/// "farther than limit_mm".
double distance_to_organ_mm(const MaskImage& mask, const std::array<double, 3>& point_mm, double limit_mm);

}  // namespace organsim::pipeline

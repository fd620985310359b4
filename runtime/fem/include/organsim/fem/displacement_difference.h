// How far one solution's nodal displacements are from a reference's, in the
// two normalizations the docs use. Units: the inputs' (m); results are
// fractions (0.01 = 1 %).
#pragma once

#include <Eigen/Core>

namespace organsim::fem {

struct DisplacementDifference {
  /// |Δu| over the bounding box's diagonal: mean and largest over the nodes.
  double mean = 0.0, max = 0.0;
  /// |Δu_k| over the box's extent L_k along axis k: mean and largest over the
  /// nodes, per axis (x, y, z).
  Eigen::Vector3d axis_mean = Eigen::Vector3d::Zero(), axis_max = Eigen::Vector3d::Zero();

  /// Ogata et al.'s Table 5 measure: the average of the three per-axis means
  /// (their 22.0 % = (18.3 + 43.3 + 4.41) / 3 for the linear FEM) ...
  double paper_mean() const noexcept { return axis_mean.mean(); }
  /// ... and the largest single component (their 96.2 %).
  double paper_max() const noexcept { return axis_max.maxCoeff(); }
};

/// Compares the nodes' positions (or displacements: the rest shape is shared,
/// so their differences are the same), one column per node, against the
/// reference's; `extent` is the organ's bounding box size (all > 0).
DisplacementDifference displacement_difference(const Eigen::Ref<const Eigen::Matrix3Xd>& positions,
                                               const Eigen::Ref<const Eigen::Matrix3Xd>& reference,
                                               const Eigen::Vector3d& extent);

}  // namespace organsim::fem

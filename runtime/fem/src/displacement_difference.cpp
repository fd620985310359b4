#include "organsim/fem/displacement_difference.h"

#include <algorithm>

namespace organsim::fem {

DisplacementDifference displacement_difference(const Eigen::Ref<const Eigen::Matrix3Xd>& positions,
                                               const Eigen::Ref<const Eigen::Matrix3Xd>& reference,
                                               const Eigen::Vector3d& extent) {
  DisplacementDifference d;
  const double diagonal = extent.norm();
  const Eigen::Index n = positions.cols();
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector3d delta = positions.col(i) - reference.col(i);
    const double distance = delta.norm() / diagonal;
    const Eigen::Vector3d per_axis = delta.cwiseAbs().cwiseQuotient(extent);
    d.mean += distance;
    d.max = std::max(d.max, distance);
    d.axis_mean += per_axis;
    d.axis_max = d.axis_max.cwiseMax(per_axis);
  }
  if (n > 0) {
    d.mean /= static_cast<double>(n);
    d.axis_mean /= static_cast<double>(n);
  }
  return d;
}

}  // namespace organsim::fem

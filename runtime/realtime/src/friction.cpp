#include "organsim/realtime/friction.h"

#include <algorithm>

#include <Eigen/Geometry>
#include <Eigen/LU>

namespace organsim::realtime {

Eigen::Vector3d slip_step(const Eigen::Matrix3d& stiffness, const Eigen::Vector3d& normal, double friction,
                          Eigen::Vector3d& force) noexcept {
  const double allowed = friction * std::max(force.dot(normal), 0.0);
  const Eigen::Vector3d tangential = force - force.dot(normal) * normal;
  const double magnitude = tangential.norm();
  if (!(magnitude > allowed) || magnitude == 0.0) return Eigen::Vector3d::Zero();
  // The shift within the tangent plane that takes the excess off the
  // tangential force through the stiffness's tangential block (the 2 × 2
  // system; its coupling to the normal direction is left to the next step).
  const Eigen::Vector3d excess = (1.0 - allowed / magnitude) * tangential;
  Eigen::Matrix<double, 3, 2> plane;
  plane.col(0) = tangential / magnitude;
  plane.col(1) = normal.cross(plane.col(0));
  const Eigen::Matrix2d block = plane.transpose() * stiffness * plane;
  Eigen::Vector3d shift;
  if (block.determinant() > 0.0 && block.trace() > 0.0) {
    shift = plane * block.inverse() * (plane.transpose() * excess);
  } else {
    const double along = plane.col(0).dot(stiffness * plane.col(0));
    if (!(along > 0.0)) return Eigen::Vector3d::Zero();
    shift = excess.norm() / along * plane.col(0);
  }
  force.noalias() -= stiffness * shift;
  return shift;
}

void clip_to_cone(const Eigen::Vector3d& normal, double friction, Eigen::Vector3d& force) noexcept {
  if (force.dot(normal) < 0.0) force -= force.dot(normal) * normal;
  const double allowed = friction * force.dot(normal);
  const Eigen::Vector3d tangential = force - force.dot(normal) * normal;
  const double magnitude = tangential.norm();
  if (magnitude > allowed) force -= (1.0 - allowed / magnitude) * tangential;
}

}  // namespace organsim::realtime

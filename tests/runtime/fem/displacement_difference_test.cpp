// Ogata et al.'s Table 5 measure and the diagonal measure, worked by hand.
#include "organsim/fem/displacement_difference.h"

#include <gtest/gtest.h>

#include <cmath>

namespace organsim::fem {
namespace {

TEST(DisplacementDifference, TwoNodesByHand) {
  // A box of 0.1 × 0.2 × 0.4 m (diagonal √0.21 m). Node 0 is off by
  // (0.01, 0, 0.04) m, node 1 by (0, −0.02, 0) m.
  const Eigen::Vector3d extent(0.1, 0.2, 0.4);
  Eigen::Matrix3Xd reference(3, 2), positions(3, 2);
  reference << 1, 2, 3, 4, 5, 6;
  positions = reference;
  positions.col(0) += Eigen::Vector3d(0.01, 0, 0.04);
  positions.col(1) += Eigen::Vector3d(0, -0.02, 0);
  const DisplacementDifference d = displacement_difference(positions, reference, extent);
  // Per axis: x 0.1 and 0 → mean 0.05, max 0.1; y 0 and 0.1 → 0.05, 0.1; z 0.1 and 0 → 0.05, 0.1.
  EXPECT_NEAR(d.axis_mean.x(), 0.05, 1e-15);
  EXPECT_NEAR(d.axis_mean.y(), 0.05, 1e-15);
  EXPECT_NEAR(d.axis_mean.z(), 0.05, 1e-15);
  EXPECT_NEAR(d.axis_max.x(), 0.1, 1e-15);
  EXPECT_NEAR(d.axis_max.y(), 0.1, 1e-15);
  EXPECT_NEAR(d.axis_max.z(), 0.1, 1e-15);
  EXPECT_NEAR(d.paper_mean(), 0.05, 1e-15);
  EXPECT_NEAR(d.paper_max(), 0.1, 1e-15);
  // The diagonal measure: |Δu| = √0.0017 and 0.02 over √0.21.
  const double diagonal = std::sqrt(0.21);
  EXPECT_NEAR(d.mean, (std::sqrt(0.0017) + 0.02) / 2 / diagonal, 1e-15);
  EXPECT_NEAR(d.max, std::sqrt(0.0017) / diagonal, 1e-15);
}

TEST(DisplacementDifference, ThePapersMaxIsTheLargestComponentNotTheLargestDistance) {
  // Node 0 is off diagonally by 0.03 in each axis (the larger distance); node
  // 1 by 0.04 in x alone (the larger single component).
  const Eigen::Vector3d extent(1, 1, 1);
  Eigen::Matrix3Xd reference = Eigen::Matrix3Xd::Zero(3, 2), positions(3, 2);
  positions << 0.03, 0.04, 0.03, 0, 0.03, 0;
  const DisplacementDifference d = displacement_difference(positions, reference, extent);
  EXPECT_NEAR(d.paper_max(), 0.04, 1e-15);
  EXPECT_NEAR(d.paper_mean(), (0.035 + 0.015 + 0.015) / 3, 1e-15);
  EXPECT_NEAR(d.max, 0.03, 1e-15);  // |Δu| = 0.03 √3 over the diagonal √3
}

TEST(DisplacementDifference, TheSameSolutionDiffersByNothing) {
  const Eigen::Matrix3Xd positions = Eigen::Matrix3Xd::Random(3, 5);
  const DisplacementDifference d = displacement_difference(positions, positions, Eigen::Vector3d(1, 2, 3));
  EXPECT_EQ(d.mean, 0.0);
  EXPECT_EQ(d.max, 0.0);
  EXPECT_EQ(d.paper_mean(), 0.0);
  EXPECT_EQ(d.paper_max(), 0.0);
}

}  // namespace
}  // namespace organsim::fem

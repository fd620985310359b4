// The tool's capsule end (geometry/tool_tip.h): where a tilted tip touches.
#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/Geometry>

#include "organsim/geometry/tool_tip.h"

namespace organsim::geometry {
namespace {

TEST(ToolTip, ASeatedTiltedTipRestsOnTheSurfaceAtTheTouchedPoint) {
  // The plane z = 0 (outward normal +z) touched at the origin by a 2.5 mm tip
  // whose shaft is tilted θ from the normal. Unseated, its foremost point at
  // the touched point, the hemisphere's side is R(1 − cos θ) below the plane;
  // seated, no point of the plane is inside it and the touched point is on it.
  const Eigen::Vector3d normal = Eigen::Vector3d::UnitZ(), touched = Eigen::Vector3d::Zero();
  for (const double tilt_degrees : {0.0, 30.0, 45.0, 70.0}) {
    ToolTip tip;
    tip.radius = 2.5e-3;
    const double tilt = tilt_degrees * M_PI / 180.0;
    tip.axis = Eigen::Vector3d(std::sin(tilt), 0.0, std::cos(tilt));
    double deepest_unseated = 0.0, deepest_seated = 0.0;
    Eigen::Vector3d away;
    for (double x = -5e-3; x <= 5e-3; x += 1e-5) {
      const Eigen::Vector3d on_plane(x, 0.0, 0.0);
      deepest_unseated = std::min(deepest_unseated, tip.signed_distance(touched, on_plane, away));
    }
    tip.seat_on(normal);
    for (double x = -5e-3; x <= 5e-3; x += 1e-5)
      for (double y = -5e-3; y <= 5e-3; y += 5e-4) {
        const Eigen::Vector3d on_plane(x, y, 0.0);
        deepest_seated = std::min(deepest_seated, tip.signed_distance(touched + tip.seat, on_plane, away));
      }
    EXPECT_NEAR(deepest_unseated, -tip.radius * (1.0 - std::cos(tilt)), 1e-7) << tilt_degrees;
    EXPECT_GE(deepest_seated, -1e-12) << tilt_degrees;
    EXPECT_NEAR(tip.signed_distance(touched + tip.seat, touched, away), 0.0, 1e-12) << tilt_degrees;
    EXPECT_NEAR((away + normal).norm(), 0.0, 1e-12) << tilt_degrees;  // it pushes the touched point inward
    if (tilt_degrees == 0.0) {
      EXPECT_EQ(tip.seat, Eigen::Vector3d::Zero());
    }
  }
}

TEST(ToolTip, AShaftPointingIntoTheOrganIsNotSeatedAndAPointToolNever) {
  ToolTip tip;
  tip.radius = 2.5e-3;
  tip.axis = -Eigen::Vector3d::UnitZ();
  tip.seat_on(Eigen::Vector3d::UnitZ());
  EXPECT_EQ(tip.seat, Eigen::Vector3d::Zero());
  ToolTip point;
  point.axis = Eigen::Vector3d(1.0, 0.0, 1.0).normalized();
  point.seat_on(Eigen::Vector3d::UnitZ());
  EXPECT_EQ(point.seat, Eigen::Vector3d::Zero());
}

}  // namespace
}  // namespace organsim::geometry

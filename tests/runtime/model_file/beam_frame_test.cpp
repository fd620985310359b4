#include <gtest/gtest.h>

#include <cmath>

#include "organsim/model/beam_frame.h"

namespace organsim {
namespace {

double dot(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

TEST(BeamFrame, IsRightHandedOrthonormal) {
  const std::array<double, 3> from{0.01, -0.02, 0.03};
  for (const std::array<double, 3>& to : {std::array<double, 3>{0.1, 0.0, 0.0},
                                          {0.0, 0.2, 0.0},
                                          {0.0, 0.0, -0.3},
                                          {0.05, 0.07, -0.02},
                                          {-1e-6, 2e-6, 3e-6}}) {
    model::BeamFrame f;
    ASSERT_TRUE(model::make_beam_frame(from, to, f));
    EXPECT_NEAR(dot(f.x, f.x), 1.0, 1e-12);
    EXPECT_NEAR(dot(f.y, f.y), 1.0, 1e-12);
    EXPECT_NEAR(dot(f.z, f.z), 1.0, 1e-12);
    EXPECT_NEAR(dot(f.x, f.y), 0.0, 1e-12);
    EXPECT_NEAR(dot(f.x, f.z), 0.0, 1e-12);
    const std::array<double, 3> xy{f.x[1] * f.y[2] - f.x[2] * f.y[1], f.x[2] * f.y[0] - f.x[0] * f.y[2],
                                   f.x[0] * f.y[1] - f.x[1] * f.y[0]};
    EXPECT_NEAR(dot(xy, f.z), 1.0, 1e-12);
    const std::array<double, 3> axis{to[0] - from[0], to[1] - from[1], to[2] - from[2]};
    EXPECT_NEAR(dot(f.x, axis), std::sqrt(dot(axis, axis)), 1e-12);
  }
}

TEST(BeamFrame, FollowsTheDocumentedConvention) {
  model::BeamFrame f;
  ASSERT_TRUE(model::make_beam_frame({0, 0, 0}, {2, 0, 0}, f));
  // x along world X: Y is the first least-aligned axis, so y = Y and z = Z.
  EXPECT_EQ(f.y, (std::array<double, 3>{0, 1, 0}));
  EXPECT_EQ(f.z, (std::array<double, 3>{0, 0, 1}));
  ASSERT_TRUE(model::make_beam_frame({0, 0, 0}, {0, 0, 1}, f));
  EXPECT_EQ(f.y, (std::array<double, 3>{1, 0, 0}));
  EXPECT_EQ(f.z, (std::array<double, 3>{0, 1, 0}));
}

TEST(BeamFrame, RejectsDegenerateBeams) {
  model::BeamFrame f{{9, 9, 9}, {9, 9, 9}, {9, 9, 9}};
  EXPECT_FALSE(model::make_beam_frame({1, 2, 3}, {1, 2, 3}, f));
  EXPECT_FALSE(model::make_beam_frame({0, 0, 0}, {NAN, 0, 0}, f));
  EXPECT_EQ(f.x, (std::array<double, 3>{9, 9, 9}));
}

}  // namespace
}  // namespace organsim

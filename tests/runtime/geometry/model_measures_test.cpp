// The surface's edge stretch (geometry/model_measures.h): what the training
// report's strain and `calibrate --evaluate`'s stretch factor read.
#include <gtest/gtest.h>

#include <cmath>

#include "organsim/geometry/model_measures.h"

namespace organsim::geometry {
namespace {

TEST(ModelMeasures, EdgeStretchIsTheEdgesLengthOverItsRestLength) {
  const std::vector<model::Point3> rest = {{0, 0, 0}, {0.01, 0, 0}, {0, 0.02, 0}, {0, 0.02, 0}};
  // The first edge drawn out to 1.3 times its length, the second shortened to half.
  std::vector<model::Point3> now = {{0, 0, 0}, {0.013, 0, 0}, {0, 0.01, 0}, {0.5, 0.5, 0.5}};
  EXPECT_DOUBLE_EQ(edge_stretch(rest, now, 0, 1), 1.3);
  EXPECT_DOUBLE_EQ(edge_stretch(rest, now, 0, 2), 0.5);
  EXPECT_DOUBLE_EQ(edge_stretch(rest, now, 1, 0), 1.3);
  EXPECT_DOUBLE_EQ(edge_stretch(rest, now, 2, 3), 1.0);  // no length at rest: nothing to measure
  EXPECT_DOUBLE_EQ(edge_stretch(rest, now, 1, 2), std::hypot(0.013, 0.01) / std::hypot(0.01, 0.02));
  EXPECT_DOUBLE_EQ(largest_edge_stretch(rest, now, {{0, 1, 2}}), 1.3);
  // A surface moved rigidly stretches nothing; compressed everywhere, its largest stretch is 1.
  const std::vector<model::Point3> moved = {{1, 2, 3}, {1.01, 2, 3}, {1, 2.02, 3}, {1, 2.02, 3}};
  EXPECT_DOUBLE_EQ(largest_edge_stretch(rest, moved, {{0, 1, 2}}), 1.0);
  const std::vector<model::Point3> shrunk = {{0, 0, 0}, {0.005, 0, 0}, {0, 0.01, 0}, {0, 0.01, 0}};
  EXPECT_DOUBLE_EQ(largest_edge_stretch(rest, shrunk, {{0, 1, 2}}), 1.0);
}

}  // namespace
}  // namespace organsim::geometry

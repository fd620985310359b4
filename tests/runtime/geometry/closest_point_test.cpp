#include <random>

#include <gtest/gtest.h>

#include "organsim/geometry/closest_point.h"
#include "test_models.h"

namespace organsim {
namespace {

Eigen::Vector3d vec(const model::Point3& p) { return {p[0], p[1], p[2]}; }

TEST(ClosestPoint, BarycentricWeightsCoverFaceEdgesAndVertices) {
  const Eigen::Vector3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  EXPECT_TRUE(geometry::closest_point_barycentric({0.25, 0.25, 3.0}, a, b, c).isApprox(Eigen::Vector3d(0.5, 0.25, 0.25)));
  EXPECT_TRUE(geometry::closest_point_barycentric({-1.0, -1.0, 0.0}, a, b, c).isApprox(Eigen::Vector3d(1, 0, 0)));
  EXPECT_TRUE(geometry::closest_point_barycentric({2.0, -0.5, 0.0}, a, b, c).isApprox(Eigen::Vector3d(0, 1, 0)));
  EXPECT_TRUE(geometry::closest_point_barycentric({0.5, -1.0, 0.0}, a, b, c).isApprox(Eigen::Vector3d(0.5, 0.5, 0)));
  EXPECT_TRUE(geometry::closest_point_barycentric({1.0, 1.0, 0.0}, a, b, c).isApprox(Eigen::Vector3d(0, 0.5, 0.5)));
}

TEST(SurfaceBvh, MatchesBruteForceOnASphere) {
  const model::OrganModel model = testing::make_sphere_model(2000, 4);
  const geometry::SurfaceBvh tree(model.surface_vertices, model.surface_triangles);
  std::mt19937 random(11);
  std::uniform_real_distribution<double> coordinate(-0.2, 0.2);
  for (int trial = 0; trial < 300; ++trial) {
    const Eigen::Vector3d q(coordinate(random), coordinate(random), coordinate(random));
    double best = std::numeric_limits<double>::infinity();
    for (const model::Triangle& t : model.surface_triangles) {
      const Eigen::Vector3d a = vec(model.surface_vertices[t[0]]), b = vec(model.surface_vertices[t[1]]),
                            c = vec(model.surface_vertices[t[2]]);
      const Eigen::Vector3d w = geometry::closest_point_barycentric(q, a, b, c);
      best = std::min(best, (w[0] * a + w[1] * b + w[2] * c - q).norm());
    }
    const geometry::SurfacePoint found = tree.closest_point(q);
    EXPECT_NEAR(found.distance, best, 1e-14) << trial;
    const model::Triangle& t = model.surface_triangles[found.triangle];
    const Eigen::Vector3d rebuilt = found.barycentric[0] * vec(model.surface_vertices[t[0]]) +
                                    found.barycentric[1] * vec(model.surface_vertices[t[1]]) +
                                    found.barycentric[2] * vec(model.surface_vertices[t[2]]);
    EXPECT_LT((rebuilt - found.position).norm(), 1e-14);
  }
}

}  // namespace
}  // namespace organsim

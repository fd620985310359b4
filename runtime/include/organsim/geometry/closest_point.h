// Closest points on triangles and on a closed triangle surface (SI units, m).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "organsim/model/organ_model.h"

namespace organsim {

/// The point of triangle (a, b, c) closest to p, as barycentric weights
/// (w_a, w_b, w_c), each in [0, 1], summing to 1 (Ericson, Real-Time Collision
/// Detection, §5.1.5: Voronoi regions of vertices, edges and face).
Eigen::Vector3d closest_point_barycentric(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                          const Eigen::Vector3d& c) noexcept;

/// A point on a surface: the triangle, its barycentric weights, the position.
struct SurfacePoint {
  std::uint32_t triangle = 0;
  Eigen::Vector3d barycentric = Eigen::Vector3d::Zero();
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double distance = 0.0;  ///< from the query point, m
};

/// An axis-aligned bounding-box tree over a fixed triangle surface for
/// closest-point queries. Built once (allocates); queries allocate nothing.
class SurfaceBvh {
 public:
  SurfaceBvh(const std::vector<Point3>& vertices, const std::vector<Triangle>& triangles);

  /// The surface point closest to `query` (finite). Exact: every triangle whose
  /// box could hold a closer point is tested.
  SurfacePoint closest_point(const Eigen::Vector3d& query) const noexcept;

 private:
  struct Node {
    Eigen::AlignedBox3d box;
    std::uint32_t first = 0;  ///< leaf: first entry in order_; inner: left child
    std::uint32_t count = 0;  ///< leaf: triangle count; inner: 0
    std::uint32_t right = 0;  ///< inner: right child
  };
  std::uint32_t build(std::uint32_t first, std::uint32_t count, std::vector<Eigen::Vector3d>& centroids);

  const std::vector<Point3>& vertices_;
  const std::vector<Triangle>& triangles_;
  std::vector<std::uint32_t> order_;
  std::vector<Node> nodes_;
};

}  // namespace organsim

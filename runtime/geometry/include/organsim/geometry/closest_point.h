// Closest points on triangles and on a closed triangle surface (SI units, m).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "organsim/model/organ_model.h"

namespace organsim::geometry {

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

/// Where a segment first crosses a surface.
struct SegmentHit {
  std::uint32_t triangle = 0;
  Eigen::Vector3d barycentric = Eigen::Vector3d::Zero();
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  double along = 0.0;     ///< segment parameter of the crossing, in [0, 1]
  bool entering = false;  ///< the segment runs against the triangle's outward normal
};

/// An axis-aligned bounding-box tree over a triangle surface for closest-point
/// and segment queries. Built once on the rest positions (allocates); when the
/// surface deforms, refit() recomputes the boxes for new positions without
/// changing the tree (no allocation). Queries allocate nothing.
class SurfaceBvh {
 public:
  SurfaceBvh(const std::vector<model::Point3>& vertices, const std::vector<model::Triangle>& triangles);

  /// Makes the tree describe the same triangles at `positions` (one per vertex,
  /// kept by pointer until the next refit): boxes recomputed bottom-up.
  void refit(const model::Point3* positions) noexcept;

  /// The same, recomputing only the boxes above the `count` vertices in
  /// `moved` (the paper's partial refit: the leaves holding a triangle at a
  /// moved vertex, and their ancestors). Exact when every other vertex has at
  /// `positions` the coordinates it had at the last refit. Indices out of
  /// range and repeats are ignored; allocates nothing.
  void refit(const model::Point3* positions, const std::uint32_t* moved, std::size_t count) noexcept;

  /// The surface point closest to `query` (finite). Exact: every triangle whose
  /// box could hold a closer point is tested.
  SurfacePoint closest_point(const Eigen::Vector3d& query) const noexcept;

  /// The first crossing of the segment from `from` to `to` with the surface
  /// (smallest segment parameter), if any. With `entering_only`, crossings
  /// from inside to outside are ignored.
  bool first_crossing(const Eigen::Vector3d& from, const Eigen::Vector3d& to, bool entering_only,
                      SegmentHit& hit) const noexcept;

 private:
  struct Node {
    Eigen::AlignedBox3d box;
    std::uint32_t first = 0;  ///< leaf: first entry in order_; inner: left child
    std::uint32_t count = 0;  ///< leaf: triangle count; inner: 0
    std::uint32_t right = 0;  ///< inner: right child
  };
  std::uint32_t build(std::uint32_t first, std::uint32_t count, std::vector<Eigen::Vector3d>& centroids);
  void fit(Node& node) const noexcept;

  const model::Point3* vertices_;
  const std::vector<model::Triangle>& triangles_;
  std::vector<std::uint32_t> order_;
  std::vector<Node> nodes_;
  // For the partial refit: each node's parent, each vertex's leaves (CSR),
  // and a mark per node.
  std::vector<std::uint32_t> parent_;
  std::vector<std::uint32_t> vertex_leaf_offset_, vertex_leaves_;
  std::vector<std::uint8_t> marked_;
};

}  // namespace organsim::geometry

#include "organsim/geometry/closest_point.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <utility>

namespace organsim::geometry {
namespace {

Eigen::Vector3d point(const model::Point3& p) { return {p[0], p[1], p[2]}; }

constexpr std::uint32_t kLeafSize = 4;
constexpr int kMaxDepth = 64;  // median splits: depth ≤ log2(triangles) + 1
// Barycentric slack of the segment test: far above the rounding of u and v
// (about 1e-16 for any triangle that is not a needle), far below a point's
// meaning (1e-9 of a 10 mm edge is 10 pm).
constexpr double kEdgeSlack = 1e-9;

}  // namespace

Eigen::Vector3d closest_point_barycentric(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                          const Eigen::Vector3d& c) noexcept {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return {1.0, 0.0, 0.0};
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return {0.0, 1.0, 0.0};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
    const double v = d1 / (d1 - d3);
    return {1.0 - v, v, 0.0};
  }
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return {0.0, 0.0, 1.0};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
    const double w = d2 / (d2 - d6);
    return {1.0 - w, 0.0, w};
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return {0.0, 1.0 - w, w};
  }
  const double denominator = va + vb + vc;
  if (!(denominator > 0.0)) return {1.0, 0.0, 0.0};  // degenerate triangle: its first vertex
  const double v = vb / denominator, w = vc / denominator;
  return {1.0 - v - w, v, w};
}

SurfaceBvh::SurfaceBvh(const std::vector<model::Point3>& vertices, const std::vector<model::Triangle>& triangles)
    : vertices_(vertices.data()), triangles_(triangles), order_(triangles.size()) {
  std::iota(order_.begin(), order_.end(), 0u);
  std::vector<Eigen::Vector3d> centroids(triangles.size());
  for (std::size_t t = 0; t < triangles.size(); ++t)
    centroids[t] =
        (point(vertices[triangles[t][0]]) + point(vertices[triangles[t][1]]) + point(vertices[triangles[t][2]])) / 3.0;
  nodes_.reserve(2 * triangles.size() / kLeafSize + 2);
  if (!triangles.empty()) build(0, static_cast<std::uint32_t>(triangles.size()), centroids);
  refit(vertices_);

  parent_.assign(nodes_.size(), 0);
  for (std::uint32_t k = 0; k < nodes_.size(); ++k)
    if (nodes_[k].count == 0) parent_[nodes_[k].first] = parent_[nodes_[k].right] = k;
  // Each vertex's leaves, ascending and without repeats: counted, filled,
  // then each vertex's short list sorted (a global sort of 600k pairs cost
  // a quarter of loading a 100k-vertex model).
  const std::size_t n = vertices.size();
  std::vector<std::uint32_t> offset(n + 1, 0), leaves;
  for (const Node& node : nodes_)
    for (std::uint32_t i = node.first; node.count > 0 && i < node.first + node.count; ++i)
      for (std::uint32_t corner : triangles_[order_[i]]) ++offset[corner + 1];
  for (std::size_t v = 0; v < n; ++v) offset[v + 1] += offset[v];
  leaves.resize(offset[n]);
  std::vector<std::uint32_t> fill(offset.begin(), offset.end() - 1);
  for (std::uint32_t k = 0; k < nodes_.size(); ++k)
    for (std::uint32_t i = nodes_[k].first; nodes_[k].count > 0 && i < nodes_[k].first + nodes_[k].count; ++i)
      for (std::uint32_t corner : triangles_[order_[i]]) leaves[fill[corner]++] = k;
  vertex_leaf_offset_.assign(n + 1, 0);
  vertex_leaves_.reserve(leaves.size());
  for (std::size_t v = 0; v < n; ++v) {
    const auto begin = leaves.begin() + offset[v], end = leaves.begin() + offset[v + 1];
    std::sort(begin, end);
    const auto last = std::unique(begin, end);
    vertex_leaves_.insert(vertex_leaves_.end(), begin, last);
    vertex_leaf_offset_[v + 1] = static_cast<std::uint32_t>(vertex_leaves_.size());
  }
  marked_.assign(nodes_.size(), 0);
}

void SurfaceBvh::fit(Node& node) const noexcept {
  node.box.setEmpty();
  if (node.count > 0) {
    for (std::uint32_t i = node.first; i < node.first + node.count; ++i)
      for (std::uint32_t corner : triangles_[order_[i]]) node.box.extend(point(vertices_[corner]));
  } else {
    node.box.extend(nodes_[node.first].box);
    node.box.extend(nodes_[node.right].box);
  }
}

std::uint32_t SurfaceBvh::build(std::uint32_t first, std::uint32_t count, std::vector<Eigen::Vector3d>& centroids) {
  // Only the centroids' box here; the nodes' boxes are fitted bottom-up once
  // the tree stands (one pass over the triangles instead of one per level).
  const auto index = static_cast<std::uint32_t>(nodes_.size());
  nodes_.emplace_back();
  Eigen::AlignedBox3d centre_box;
  for (std::uint32_t i = first; i < first + count; ++i) centre_box.extend(centroids[order_[i]]);
  if (count <= kLeafSize) {
    nodes_[index].first = first;
    nodes_[index].count = count;
    return index;
  }
  int axis = 0;
  centre_box.sizes().maxCoeff(&axis);
  const std::uint32_t half = count / 2;
  // Ties broken by triangle index so the tree does not depend on the sort.
  std::nth_element(order_.begin() + first, order_.begin() + first + half, order_.begin() + first + count,
                   [&](std::uint32_t a, std::uint32_t b) {
                     return centroids[a][axis] < centroids[b][axis] ||
                            (centroids[a][axis] == centroids[b][axis] && a < b);
                   });
  const std::uint32_t left = build(first, half, centroids);
  const std::uint32_t right = build(first + half, count - half, centroids);
  nodes_[index].first = left;
  nodes_[index].right = right;
  nodes_[index].count = 0;
  return index;
}

void SurfaceBvh::refit(const model::Point3* positions) noexcept {
  vertices_ = positions;
  // Children are created after their parent, so a reverse sweep sees both
  // children of a node before the node.
  for (std::size_t k = nodes_.size(); k-- > 0;) fit(nodes_[k]);
}

void SurfaceBvh::refit(const model::Point3* positions, const std::uint32_t* moved, std::size_t count) noexcept {
  vertices_ = positions;
  const std::size_t vertex_count = vertex_leaf_offset_.size() - 1;
  for (std::size_t m = 0; m < count; ++m) {
    const std::uint32_t vertex = moved[m];
    if (vertex >= vertex_count) continue;
    for (std::uint32_t e = vertex_leaf_offset_[vertex]; e < vertex_leaf_offset_[vertex + 1]; ++e)
      for (std::uint32_t node = vertex_leaves_[e]; !marked_[node]; node = parent_[node]) {
        marked_[node] = 1;
        if (node == 0) break;
      }
  }
  // A sweep over the marks (a byte per node) costs less than sorting the
  // marked nodes; children come after their parent, so in decreasing index
  // order both children of a node are refitted before it.
  for (std::size_t k = nodes_.size(); k-- > 0;)
    if (marked_[k]) {
      fit(nodes_[k]);
      marked_[k] = 0;
    }
}

bool SurfaceBvh::first_crossing(const Eigen::Vector3d& from, const Eigen::Vector3d& to, bool entering_only,
                                SegmentHit& hit) const noexcept {
  if (nodes_.empty() || !from.allFinite() || !to.allFinite()) return false;
  const Eigen::Vector3d direction = to - from;
  bool found = false;
  double best = std::numeric_limits<double>::infinity();
  std::uint32_t stack[kMaxDepth * 2];
  int top = 0;
  stack[top++] = 0;
  const Eigen::AlignedBox3d segment_box(from.cwiseMin(to), from.cwiseMax(to));
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (!node.box.intersects(segment_box)) continue;
    if (node.count == 0) {
      stack[top++] = node.first;
      stack[top++] = node.right;
      continue;
    }
    for (std::uint32_t i = node.first; i < node.first + node.count; ++i) {
      // Möller–Trumbore on the closed triangle, widened by kEdgeSlack: a
      // segment through an edge or a vertex is tested by every triangle there
      // with its own rounding, and on the exact triangles all of them could
      // miss it (measured: 6 % of the segments through a vertex of the test cylinder).
      const model::Triangle& t = triangles_[order_[i]];
      const Eigen::Vector3d a = point(vertices_[t[0]]), b = point(vertices_[t[1]]), c = point(vertices_[t[2]]);
      const Eigen::Vector3d ab = b - a, ac = c - a;
      const Eigen::Vector3d p = direction.cross(ac);
      const double determinant = ab.dot(p);
      if (determinant == 0.0) continue;         // parallel to the plane
      const bool entering = determinant > 0.0;  // against the outward normal ab × ac
      if (entering_only && !entering) continue;
      const double inverse = 1.0 / determinant;
      const Eigen::Vector3d s = from - a;
      const double u = s.dot(p) * inverse;
      if (u < -kEdgeSlack || u > 1.0 + kEdgeSlack) continue;
      const Eigen::Vector3d q = s.cross(ab);
      const double v = direction.dot(q) * inverse;
      if (v < -kEdgeSlack || u + v > 1.0 + kEdgeSlack) continue;
      const double along = ac.dot(q) * inverse;
      if (along < 0.0 || along > 1.0 || along >= best) continue;
      best = along;
      found = true;
      hit.triangle = order_[i];
      // Back onto the triangle: a hit in the slack is on its edge.
      const Eigen::Vector3d weights = Eigen::Vector3d(1.0 - u - v, u, v).cwiseMax(0.0);
      hit.barycentric = weights / weights.sum();
      hit.position = from + along * direction;
      hit.along = along;
      hit.entering = entering;
    }
  }
  return found;
}

SurfacePoint SurfaceBvh::closest_point(const Eigen::Vector3d& query) const noexcept {
  SurfacePoint best;
  double best_squared = std::numeric_limits<double>::infinity();
  if (nodes_.empty()) return best;
  std::uint32_t stack[kMaxDepth * 2];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& node = nodes_[stack[--top]];
    if (node.box.squaredExteriorDistance(query) >= best_squared) continue;
    if (node.count > 0) {
      for (std::uint32_t i = node.first; i < node.first + node.count; ++i) {
        const model::Triangle& t = triangles_[order_[i]];
        const Eigen::Vector3d a = point(vertices_[t[0]]), b = point(vertices_[t[1]]), c = point(vertices_[t[2]]);
        const Eigen::Vector3d weights = closest_point_barycentric(query, a, b, c);
        const Eigen::Vector3d candidate = weights[0] * a + weights[1] * b + weights[2] * c;
        const double squared = (candidate - query).squaredNorm();
        if (squared < best_squared) {
          best_squared = squared;
          best.triangle = order_[i];
          best.barycentric = weights;
          best.position = candidate;
        }
      }
      continue;
    }
    // Visit the nearer child first so that far subtrees are pruned.
    const std::uint32_t left = node.first, right = node.right;
    const bool left_nearer =
        nodes_[left].box.squaredExteriorDistance(query) <= nodes_[right].box.squaredExteriorDistance(query);
    stack[top++] = left_nearer ? right : left;
    stack[top++] = left_nearer ? left : right;
  }
  best.distance = std::sqrt(best_squared);
  return best;
}

}  // namespace organsim::geometry

// The tetrahedral mesh the FEM models solve on (P1: one node per vertex), and
// the generated meshes the tests and the paper's reproduction use.
// Units: metres.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/StdVector>

namespace organsim::fem {

using Points = std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>>;
using Tetrahedron = std::array<std::int32_t, 4>;

struct TetMesh {
  Points nodes;                         ///< m
  std::vector<Tetrahedron> tetrahedra;  ///< 0-based node indices, positive volume
};

/// Signed volume of tetrahedron `t` (m³; positive when (b − a, c − a, d − a) is right-handed).
double signed_volume(const TetMesh& mesh, const Tetrahedron& t) noexcept;
/// Smallest and largest corner of the nodes (m).
Eigen::Vector3d bounding_box_size(const Points& nodes) noexcept;

/// A box [0, size] meshed by cells.x × cells.y × cells.z cubes of six
/// tetrahedra each (Kuhn subdivision, conforming). Node (i, j, k) has index
/// i + (cells.x + 1) (j + (cells.y + 1) k).
TetMesh box_mesh(const Eigen::Vector3i& cells, const Eigen::Vector3d& size);
/// The same on the grid of the given planes (m, strictly increasing per
/// axis): a mesh graded towards where the planes are dense.
TetMesh box_mesh(const std::vector<double>& xs, const std::vector<double>& ys, const std::vector<double>& zs);

/// A vessel-like curved tube: a hollow cylinder of the given inner and outer
/// radii whose axis starts at (0, 0, length) heading down (−z) and bends
/// towards +x along a circular arc of the given length, turning by
/// `bend_angle` (rad). `rings` node rings along the axis, `around` nodes around,
/// `through` cell layers through the wall; each hexahedral cell is split into
/// six tetrahedra (the defaults: 408 nodes, 1,152 tetrahedra, near the paper's
/// 401 / 1,101).
struct TubeOptions {
  double length = 0.10, inner_radius = 0.008, outer_radius = 0.012, bend_angle = 0.6;
  int rings = 17, around = 12, through = 1;
};
TetMesh curved_tube(const TubeOptions& options);

}  // namespace organsim::fem

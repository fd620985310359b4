// Slivers out of a tetrahedral mesh: flat tetrahedra whose smallest dihedral
// angle is near zero make the FEM models' stiffness matrices ill-conditioned.
// Mesh_3's sliver exudation leaves two kinds behind on an organ: flat
// tetrahedra lying on the boundary (two faces on it) and tetrahedra spanning a
// boundary edge with two interior vertices. The first kind is peeled off, the
// second is repaired by flips and by moving its vertices. Deterministic: the
// same mesh gives the same result.
#pragma once

#include <cstddef>

#include "organsim/geometry/meshes.h"

namespace organsim::pipeline {

struct SliverRemovalOptions {
  double min_dihedral_deg = 10.0;  ///< tetrahedra with a smaller dihedral angle are slivers
  int passes = 20;                 ///< most passes of vertex moves over the slivers left
};

struct SliverRemovalReport {
  double min_dihedral_before_deg = 0.0;
  double min_dihedral_after_deg = 0.0;
  std::size_t slivers_before = 0;  ///< tetrahedra below the bound
  std::size_t slivers_after = 0;
  std::size_t peeled = 0;      ///< boundary slivers removed (two or three faces on the boundary)
  std::size_t moves = 0;       ///< vertex moves made
  std::size_t flips = 0;       ///< edge removals, face swaps and vertex insertions made
  std::size_t insertions = 0;  ///< of those, new interior vertices inserted
};

/// Removes every sliver with two faces on the boundary whose removal keeps the
/// boundary a closed 2-manifold (its two other faces become boundary; the
/// volume drops by the sliver's, a few cubic millimetres at most), and every
/// sliver at a corner of the boundary (three faces on it; its apex is left
/// unused: keep_largest_connected_part drops it). Then, in rounds while either
/// helps: flips (edge removal, face swaps, and a new interior vertex inserted
/// where its tetrahedra are best), each made where it
/// raises the worst quality of the tetrahedra it replaces and never touching
/// the boundary; and vertex moves, each to the candidate position (towards the
/// centroid of its neighbours, or away from the opposite face) that most raises
/// the worst quality of the tetrahedra around it, never lowering it and never
/// inverting a tetrahedron. Only when that is not enough does a boundary vertex
/// move: it slides in its tangent plane by at most a quarter of its edges, and
/// only where the boundary is smooth (no corner or crease), so the boundary
/// keeps its shape to second order.
SliverRemovalReport remove_slivers(geometry::TetrahedralMesh& mesh, const SliverRemovalOptions& options = {});

/// A tetrahedron's shape quality in degrees: its smallest dihedral angle, or
/// 45° / ρ when that is lower (ρ its radius–edge ratio, so that ρ = 3 reads as
/// 15°); −1 when it is inverted or flat. What sliver removal raises.
double shape_quality_deg(const model::Point3& a, const model::Point3& b, const model::Point3& c,
                         const model::Point3& d);

/// The smallest dihedral angle of one tetrahedron, degrees (0 when degenerate).
double min_dihedral_deg(const model::Point3& a, const model::Point3& b, const model::Point3& c, const model::Point3& d);

}  // namespace organsim::pipeline

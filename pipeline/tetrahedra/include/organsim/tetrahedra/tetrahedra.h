// Stage 4 of the pipeline: tetrahedra filling the organ surface (CGAL Mesh_3
// on the closed surface of stage 3), with the quality figures a user checks
// before trusting a simulation: dihedral angles, radius–edge ratios, volumes.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "organsim/geometry/meshes.h"

namespace organsim::pipeline {

/// Finer tetrahedra around a point: cells and boundary facets of `size_mm`
/// within `radius_mm` of `centre` (the model frame, m), growing by
/// kRefinementGrading mm per mm beyond it until they reach the mesh's size.
/// Where a tool of finite size presses, its force converges once the cells
/// under it are about half its radius (docs/fem.md#a-tool-of-finite-size).
struct LocalRefinement {
  model::Point3 centre{};  ///< m
  double radius_mm = 10.0;
  double size_mm = 1.25;
};

/// How fast the cells grow away from a refinement (mm of size per mm of
/// distance): gentle enough that Mesh_3's radius–edge bound keeps the
/// transition free of badly shaped tetrahedra.
constexpr double kRefinementGrading = 0.3;

/// The refinement that resolves the FEM models' clamp, the nodes within
/// `clamp_radius_m` of the fixed point (m): cells of `size_mm` over the whole
/// held ball, so that which nodes it holds no longer depends on the meshing.
LocalRefinement clamp_refinement(const model::Point3& fixed_point, double clamp_radius_m, double size_mm);

struct TetrahedraOptions {
  double tet_size_mm = 8.0;                  ///< target edge length scale: cell size and facet size, mm
  std::vector<LocalRefinement> refinements;  ///< finer cells around these points
  double facet_distance_mm = 0.4;            ///< largest distance of a boundary facet from the surface, mm
  double facet_angle_deg = 25.0;             ///< smallest boundary-facet angle (Mesh_3's facet_angle)
  double radius_edge_ratio = 3.0;            ///< largest circumradius / shortest edge of a tetrahedron
  bool optimize = true;                      ///< sliver removal (flips, peeling, vertex moves) after refinement
};

struct TetrahedralQuality {
  std::size_t tetrahedra = 0;
  double min_dihedral_deg = 0.0;
  double max_dihedral_deg = 0.0;
  double max_radius_edge_ratio = 0.0;  ///< circumradius / shortest edge; 0.612 for a regular tetrahedron
  double mean_radius_edge_ratio = 0.0;
  double min_volume_m3 = 0.0;
  double total_volume_m3 = 0.0;
};

/// Meshes the inside of `surface` (closed, manifold, outward; in metres).
/// Deterministic: the same surface and options give the same mesh. One
/// connected organ: tetrahedra joined to the largest part by no face are
/// dropped (connected_part.h). The
/// boundary vertices are offset along their normals (a fraction of a
/// millimetre) so that the tetrahedra fill the surface's volume (volume_matching.h). Throws
/// std::runtime_error with one line when the options are unusable or the
/// mesher produces no tetrahedra ("meshing failure").
geometry::TetrahedralMesh make_tetrahedra(const geometry::SurfaceMesh& surface, const TetrahedraOptions& options);

/// Quality figures of a tetrahedral mesh (empty meshes give all zeros).
TetrahedralQuality measure_quality(const geometry::TetrahedralMesh& mesh);

/// The quality a mesh should reach for the FEM models: below 12° a
/// tetrahedron's stiffness grows like 1/sin of its smallest dihedral angle and
/// the solves slow down; above 3 its circumradius is large for its shortest
/// edge (Mesh_3's own refinement bound).
constexpr double kMinDihedralGoalDeg = 12.0;
constexpr double kMaxRadiusEdgeGoal = 3.0;

/// One line per quality goal the mesh misses, saying what to do (empty when all are met).
std::vector<std::string> tetrahedra_quality_warnings(const TetrahedralQuality& quality);

}  // namespace organsim::pipeline

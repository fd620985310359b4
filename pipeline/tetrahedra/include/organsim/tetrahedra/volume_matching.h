// Volume-true boundaries. Every discrete boundary the pipeline makes has a
// small systematic volume error: the contour level between the values a block
// of voxels can take, smoothing and decimation move the surface; Mesh_3's
// boundary facets are chords of the surface and cut inside it where it is
// convex. Each is a thin layer, so one common offset along the vertex normals
// removes it: the smallest change (in the least-squares sense over the
// boundary) that gives the volume the mask measured. SI units: metres, m³.
#pragma once

#include <vector>

#include "organsim/geometry/meshes.h"

namespace organsim::pipeline {

struct VolumeMatch {
  double offset_m = 0.0;  ///< the common outward offset applied (< 0: inward)
  double volume_before_m3 = 0.0;
  double volume_after_m3 = 0.0;
};

/// Moves every vertex that a triangle of the closed, outward-oriented surface
/// uses by one common distance along its area-weighted unit normal so that the
/// surface encloses `target_m3` (Newton on the offset, to 1e-10 relative).
/// Vertices no triangle uses stay where they are. Throws std::invalid_argument
/// when the surface encloses no positive volume or the target is not positive.
VolumeMatch match_enclosed_volume(std::vector<model::Point3>& vertices, const std::vector<model::Triangle>& triangles,
                                  double target_m3);

/// The outward boundary triangles of a tetrahedral mesh of positively
/// oriented tetrahedra: the faces that exactly one tetrahedron uses.
std::vector<model::Triangle> boundary_triangles(const geometry::TetrahedralMesh& mesh);

/// match_enclosed_volume on the boundary of a tetrahedral mesh: only boundary
/// vertices move. A vertex whose move would lower a tetrahedron's shape
/// quality (shape_quality_deg) below its own and below 15° stays where it is,
/// and the others share its part; the result says what was applied.
VolumeMatch match_tetrahedra_volume(geometry::TetrahedralMesh& mesh, double target_m3);

}  // namespace organsim::pipeline

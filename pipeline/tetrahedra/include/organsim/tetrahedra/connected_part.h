// One connected organ out of Mesh_3's tetrahedra. Mesh_3 keeps a cell when its
// circumcentre lies inside the surface, so in a thin neck of the organ a lone
// tetrahedron, or a small group, can end up joined to the rest by a vertex or
// an edge only, or by nothing. The FEM models cannot hold such a part (nothing
// anchors it: their stiffness matrix is singular there), and a tetrahedron
// that sliver removal peels off a corner leaves its apex unused.
#pragma once

#include <cstddef>

#include "organsim/geometry/meshes.h"

namespace organsim::pipeline {

struct ConnectedPartReport {
  std::size_t tetrahedra_dropped = 0;  ///< tetrahedra not face-connected to the largest part
  std::size_t vertices_dropped = 0;    ///< vertices no kept tetrahedron uses
};

/// Keeps the largest set of tetrahedra connected through shared faces (by
/// count; the first such set on a tie) and the vertices they use, in their
/// order; indices are renumbered to match.
ConnectedPartReport keep_largest_connected_part(geometry::TetrahedralMesh& mesh);

}  // namespace organsim::pipeline

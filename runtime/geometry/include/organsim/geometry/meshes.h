// Plain triangle and tetrahedral meshes, in the model's units (metres) and
// frame: what the pipeline's surface and tetrahedra stages produce and what the
// mesh writers (pipeline/mesh_io) write.
#pragma once

#include <vector>

#include "organsim/model/organ_model.h"

namespace organsim::geometry {

struct SurfaceMesh {
  std::vector<model::Point3> vertices;     ///< (N × 3) m, patient frame
  std::vector<model::Triangle> triangles;  ///< (M × 3) counter-clockwise seen from outside
};

struct TetrahedralMesh {
  std::vector<model::Point3> vertices;         ///< (N × 3) m, patient frame
  std::vector<model::Tetrahedron> tetrahedra;  ///< (M × 4) positively oriented
};

}  // namespace organsim::geometry

// Writing the pipeline's meshes for inspection in 3D Slicer or ParaView. Files
// are in the patient frame (LPS) in millimetres, like the CT, so that they
// overlay it; every file is written atomically (temporary file + rename).
#pragma once

#include <string>

#include "organsim/pipeline/surface.h"
#include "organsim/pipeline/tetrahedra.h"

namespace organsim::pipeline {

/// VTK XML PolyData (.vtp). Throws std::runtime_error naming the path on failure.
void write_surface_vtp(const SurfaceMesh& surface, const std::string& path);
/// Binary STL (.stl).
void write_surface_stl(const SurfaceMesh& surface, const std::string& path);
/// VTK XML UnstructuredGrid (.vtu) of VTK_TETRA cells.
void write_tetrahedra_vtu(const TetrahedralMesh& mesh, const std::string& path);

}  // namespace organsim::pipeline

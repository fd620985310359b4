// Mesh files for inspection in 3D Slicer and ParaView: surfaces as VTK XML
// PolyData (.vtp), binary STL or OBJ, tetrahedra as VTK XML UnstructuredGrid (.vtu),
// and ParaView collections (.pvd) that index time series of such files.
//
// Coordinates are written in millimetres in the LPS patient frame, like the CT,
// so that meshes overlay it. Every VTK file says so: field data `SPACE` = "LPS"
// (the array 3D Slicer reads to pick the frame) and `UNITS` = "mm"; STL files
// carry "SPACE=LPS UNITS=mm" in their header. Every file is written atomically
// (organsim/io/atomic_file.h).
//
// Its own target (VTK's IO modules only), so that the commands that write
// meshes (`poke`, `replay`, the pipeline's intermediates) share one writer
// without linking the offline pipeline.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "organsim/geometry/meshes.h"

namespace organsim::mesh_io {

/// A named array of `components` values per point or per cell.
struct DataArray {
  std::string name;
  int components = 1;
  std::vector<double> values;  ///< (count × components), row-major
};
/// VTK XML PolyData (.vtp), with `point_data` (one tuple per vertex) where
/// given. Throws std::runtime_error naming the path on failure.
void write_surface_vtp(const geometry::SurfaceMesh& surface, const std::string& path,
                       const std::vector<DataArray>& point_data = {});
/// Binary STL (.stl).
void write_surface_stl(const geometry::SurfaceMesh& surface, const std::string& path);
/// Wavefront OBJ (.obj), for Blender and most 3-D tools (mm, LPS; OBJ has no
/// field for either).
void write_surface_obj(const geometry::SurfaceMesh& surface, const std::string& path);
/// VTK XML UnstructuredGrid (.vtu) of VTK_TETRA cells.
void write_tetrahedra_vtu(const geometry::TetrahedralMesh& mesh, const std::string& path);

/// A mesh of tetrahedra and triangles (cells in that order) with point and
/// cell data: the coordinates are written as given, field data `UNITS` says
/// `units` (a `fem` problem file's metres) and, when `space` is not empty,
/// `SPACE` says the frame (a patient model's "LPS", in mm).
struct FieldMesh {
  std::vector<std::array<double, 3>> points;
  std::vector<std::array<std::int64_t, 4>> tetrahedra;
  std::vector<std::array<std::int64_t, 3>> triangles;
  std::vector<DataArray> point_data, cell_data;
  std::string units = "m";
  std::string space;
};
/// VTK XML UnstructuredGrid (.vtu) of `mesh` with its data arrays.
void write_field_vtu(const FieldMesh& mesh, const std::string& path);

/// One entry of a time series: the time (s) and the file's name, relative to
/// the collection file.
using TimeStep = std::pair<double, std::string>;
/// A ParaView collection (.pvd) that plays `steps` as a time series.
void write_collection_pvd(const std::vector<TimeStep>& steps, const std::string& path);

}  // namespace organsim::mesh_io

#include "organsim/pipeline/mesh_io.h"

#include <vtkCellArray.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkSTLWriter.h>
#include <vtkSmartPointer.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLPolyDataWriter.h>
#include <vtkXMLUnstructuredGridWriter.h>

#include <stdexcept>

#include "atomic_output.h"

namespace organsim::pipeline {
namespace {

template <typename T>
using Ptr = vtkSmartPointer<T>;

constexpr double kMillimetresPerMetre = 1e3;

Ptr<vtkPoints> to_points_mm(const std::vector<Point3>& vertices) {
  auto points = Ptr<vtkPoints>::New();
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(static_cast<vtkIdType>(vertices.size()));
  for (std::size_t i = 0; i < vertices.size(); ++i)
    points->SetPoint(static_cast<vtkIdType>(i), vertices[i][0] * kMillimetresPerMetre,
                     vertices[i][1] * kMillimetresPerMetre, vertices[i][2] * kMillimetresPerMetre);
  return points;
}

Ptr<vtkPolyData> to_polydata(const SurfaceMesh& surface) {
  auto triangles = Ptr<vtkCellArray>::New();
  for (const Triangle& t : surface.triangles) {
    const vtkIdType ids[3] = {t[0], t[1], t[2]};
    triangles->InsertNextCell(3, ids);
  }
  auto polydata = Ptr<vtkPolyData>::New();
  polydata->SetPoints(to_points_mm(surface.vertices));
  polydata->SetPolys(triangles);
  return polydata;
}

/// Runs a VTK writer into a temporary file next to `path` and renames it.
template <typename Writer, typename Data>
void write_atomically(Writer& writer, Data* data, const std::string& path, const char* extension) {
  AtomicOutput output(path, extension);
  writer.SetInputData(data);
  writer.SetFileName(output.temp_path().c_str());
  if (writer.Write() != 1) throw std::runtime_error("cannot write '" + path + "': the VTK writer failed");
  output.commit();
}

}  // namespace

void write_surface_vtp(const SurfaceMesh& surface, const std::string& path) {
  auto writer = Ptr<vtkXMLPolyDataWriter>::New();
  writer->SetDataModeToBinary();
  write_atomically(*writer, to_polydata(surface).Get(), path, ".vtp");
}

void write_surface_stl(const SurfaceMesh& surface, const std::string& path) {
  auto writer = Ptr<vtkSTLWriter>::New();
  writer->SetFileTypeToBinary();
  write_atomically(*writer, to_polydata(surface).Get(), path, ".stl");
}

void write_tetrahedra_vtu(const TetrahedralMesh& mesh, const std::string& path) {
  auto grid = Ptr<vtkUnstructuredGrid>::New();
  grid->SetPoints(to_points_mm(mesh.vertices));
  grid->Allocate(static_cast<vtkIdType>(mesh.tetrahedra.size()));
  for (const Tetrahedron& t : mesh.tetrahedra) {
    const vtkIdType ids[4] = {t[0], t[1], t[2], t[3]};
    grid->InsertNextCell(VTK_TETRA, 4, ids);
  }
  auto writer = Ptr<vtkXMLUnstructuredGridWriter>::New();
  writer->SetDataModeToBinary();
  write_atomically(*writer, grid.Get(), path, ".vtu");
}

}  // namespace organsim::pipeline

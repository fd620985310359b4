#include "organsim/mesh_io/mesh_io.h"

#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkDoubleArray.h>
#include <vtkPointData.h>
#include <vtkFieldData.h>
#include <vtkPoints.h>
#include <vtkOBJWriter.h>
#include <vtkPolyData.h>
#include <vtkSTLWriter.h>
#include <vtkSmartPointer.h>
#include <vtkStringArray.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLPolyDataWriter.h>
#include <vtkXMLUnstructuredGridWriter.h>

#include <algorithm>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "organsim/io/atomic_file.h"

namespace organsim::mesh_io {
namespace {

template <typename T>
using Ptr = vtkSmartPointer<T>;

constexpr double kMillimetresPerMetre = 1e3;

Ptr<vtkPoints> to_points_mm(const std::vector<model::Point3>& vertices) {
  auto points = Ptr<vtkPoints>::New();
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(static_cast<vtkIdType>(vertices.size()));
  for (std::size_t i = 0; i < vertices.size(); ++i)
    points->SetPoint(static_cast<vtkIdType>(i), vertices[i][0] * kMillimetresPerMetre,
                     vertices[i][1] * kMillimetresPerMetre, vertices[i][2] * kMillimetresPerMetre);
  return points;
}

void add_string_field(vtkFieldData& fields, const char* name, const char* value) {
  auto array = Ptr<vtkStringArray>::New();
  array->SetName(name);
  array->InsertNextValue(value);
  fields.AddArray(array);
}

/// The frame and units every VTK file states (3D Slicer reads `SPACE`).
void add_frame_and_units(vtkDataObject& data) {
  add_string_field(*data.GetFieldData(), "SPACE", "LPS");
  add_string_field(*data.GetFieldData(), "UNITS", "mm");
}

Ptr<vtkPolyData> to_polydata(const geometry::SurfaceMesh& surface) {
  auto triangles = Ptr<vtkCellArray>::New();
  for (const model::Triangle& t : surface.triangles) {
    const vtkIdType ids[3] = {t[0], t[1], t[2]};
    triangles->InsertNextCell(3, ids);
  }
  auto polydata = Ptr<vtkPolyData>::New();
  polydata->SetPoints(to_points_mm(surface.vertices));
  polydata->SetPolys(triangles);
  add_frame_and_units(*polydata);
  return polydata;
}

/// Runs a VTK writer into a temporary file next to `path` and renames it.
template <typename Writer, typename Data>
void write_atomically(Writer& writer, Data* data, const std::string& path, const char* extension) {
  io::AtomicFile output(path, extension);
  writer.SetInputData(data);
  writer.SetFileName(output.temp_path().c_str());
  if (writer.Write() != 1) throw std::runtime_error("cannot write '" + path + "': the VTK writer failed");
  output.commit();
}

}  // namespace

void write_surface_stl(const geometry::SurfaceMesh& surface, const std::string& path) {
  auto writer = Ptr<vtkSTLWriter>::New();
  writer->SetFileTypeToBinary();
  writer->SetHeader("organsim surface SPACE=LPS UNITS=mm");
  write_atomically(*writer, to_polydata(surface).Get(), path, ".stl");
}

void write_surface_obj(const geometry::SurfaceMesh& surface, const std::string& path) {
  auto writer = Ptr<vtkOBJWriter>::New();
  write_atomically(*writer, to_polydata(surface).Get(), path, ".obj");
}

void write_tetrahedra_vtu(const geometry::TetrahedralMesh& mesh, const std::string& path) {
  auto grid = Ptr<vtkUnstructuredGrid>::New();
  grid->SetPoints(to_points_mm(mesh.vertices));
  grid->Allocate(static_cast<vtkIdType>(mesh.tetrahedra.size()));
  for (const model::Tetrahedron& t : mesh.tetrahedra) {
    const vtkIdType ids[4] = {t[0], t[1], t[2], t[3]};
    grid->InsertNextCell(VTK_TETRA, 4, ids);
  }
  add_frame_and_units(*grid);
  auto writer = Ptr<vtkXMLUnstructuredGridWriter>::New();
  writer->SetDataModeToBinary();
  write_atomically(*writer, grid.Get(), path, ".vtu");
}

namespace {

Ptr<vtkDoubleArray> to_vtk_array(const DataArray& data, std::size_t count, const std::string& path) {
  if (data.components < 1 || data.values.size() != count * static_cast<std::size_t>(data.components))
    throw std::invalid_argument("cannot write '" + path + "': array '" + data.name + "' has the wrong size");
  auto array = Ptr<vtkDoubleArray>::New();
  array->SetName(data.name.c_str());
  array->SetNumberOfComponents(data.components);
  array->SetNumberOfTuples(static_cast<vtkIdType>(count));
  std::copy(data.values.begin(), data.values.end(), array->GetPointer(0));
  return array;
}

}  // namespace

void write_surface_vtp(const geometry::SurfaceMesh& surface, const std::string& path,
                       const std::vector<DataArray>& point_data) {
  const Ptr<vtkPolyData> polydata = to_polydata(surface);
  for (const DataArray& data : point_data)
    polydata->GetPointData()->AddArray(to_vtk_array(data, surface.vertices.size(), path));
  auto writer = Ptr<vtkXMLPolyDataWriter>::New();
  writer->SetDataModeToBinary();
  write_atomically(*writer, polydata.Get(), path, ".vtp");
}

void write_field_vtu(const FieldMesh& mesh, const std::string& path) {
  auto points = Ptr<vtkPoints>::New();
  points->SetDataTypeToDouble();
  points->SetNumberOfPoints(static_cast<vtkIdType>(mesh.points.size()));
  for (std::size_t i = 0; i < mesh.points.size(); ++i)
    points->SetPoint(static_cast<vtkIdType>(i), mesh.points[i].data());
  auto grid = Ptr<vtkUnstructuredGrid>::New();
  grid->SetPoints(points);
  grid->Allocate(static_cast<vtkIdType>(mesh.tetrahedra.size() + mesh.triangles.size()));
  for (const auto& t : mesh.tetrahedra) {
    const vtkIdType ids[4] = {t[0], t[1], t[2], t[3]};
    grid->InsertNextCell(VTK_TETRA, 4, ids);
  }
  for (const auto& t : mesh.triangles) {
    const vtkIdType ids[3] = {t[0], t[1], t[2]};
    grid->InsertNextCell(VTK_TRIANGLE, 3, ids);
  }
  for (const DataArray& data : mesh.point_data)
    grid->GetPointData()->AddArray(to_vtk_array(data, mesh.points.size(), path));
  for (const DataArray& data : mesh.cell_data)
    grid->GetCellData()->AddArray(to_vtk_array(data, mesh.tetrahedra.size() + mesh.triangles.size(), path));
  add_string_field(*grid->GetFieldData(), "UNITS", mesh.units.c_str());
  if (!mesh.space.empty()) add_string_field(*grid->GetFieldData(), "SPACE", mesh.space.c_str());
  auto writer = Ptr<vtkXMLUnstructuredGridWriter>::New();
  writer->SetDataModeToBinary();
  write_atomically(*writer, grid.Get(), path, ".vtu");
}

void write_collection_pvd(const std::vector<TimeStep>& steps, const std::string& path) {
  std::ostringstream pvd;
  pvd << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n  <Collection>\n";
  char line[64];
  for (const auto& [time, name] : steps) {
    std::snprintf(line, sizeof line, "%.6f", time);
    pvd << "    <DataSet timestep=\"" << line << "\" file=\"" << name << "\"/>\n";
  }
  pvd << "  </Collection>\n</VTKFile>\n";
  io::write_file_atomically(path, pvd.str());
}

}  // namespace organsim::mesh_io

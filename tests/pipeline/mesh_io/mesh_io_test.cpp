// Mesh files: millimetres in the LPS frame, and each file says so (3D Slicer
// reads the `SPACE` field data); written atomically.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <vtkFieldData.h>
#include <vtkPolyData.h>
#include <vtkSTLReader.h>
#include <vtkSmartPointer.h>
#include <vtkStringArray.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLPolyDataReader.h>
#include <vtkXMLUnstructuredGridReader.h>

#include "organsim/mesh_io/mesh_io.h"
#include "temp_directory.h"

namespace organsim::mesh_io {
namespace {

namespace fs = std::filesystem;

geometry::TetrahedralMesh unit_tetrahedron() {
  return {{{0.0, 0.0, 0.0}, {0.01, 0.0, 0.0}, {0.0, 0.02, 0.0}, {0.0, 0.0, 0.03}}, {{0, 1, 2, 3}}};
}

geometry::SurfaceMesh tetrahedron_surface() {
  return {unit_tetrahedron().vertices, {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}}};
}

std::string field(vtkDataObject& data, const char* name) {
  auto* array = vtkStringArray::SafeDownCast(data.GetFieldData()->GetAbstractArray(name));
  return array && array->GetNumberOfValues() == 1 ? array->GetValue(0) : std::string("(missing)");
}

class MeshFiles : public organsim::testing::TempDirectoryTest {
 protected:
};

TEST_F(MeshFiles, SurfaceVtpIsInMillimetresAndSaysLpsAndMm) {
  const fs::path path = dir_ / "surface.vtp";
  write_surface_vtp(tetrahedron_surface(), path.string());
  auto reader = vtkSmartPointer<vtkXMLPolyDataReader>::New();
  reader->SetFileName(path.c_str());
  reader->Update();
  vtkPolyData* read = reader->GetOutput();
  ASSERT_EQ(read->GetNumberOfPoints(), 4);
  EXPECT_EQ(read->GetNumberOfPolys(), 4);
  EXPECT_DOUBLE_EQ(read->GetPoint(3)[2], 30.0);  // 0.03 m
  EXPECT_EQ(field(*read, "SPACE"), "LPS");
  EXPECT_EQ(field(*read, "UNITS"), "mm");
  EXPECT_EQ(entries(), 1);  // no temporary left
}

TEST_F(MeshFiles, TetrahedraVtuSaysLpsAndMm) {
  const fs::path path = dir_ / "tetrahedra.vtu";
  write_tetrahedra_vtu(unit_tetrahedron(), path.string());
  auto reader = vtkSmartPointer<vtkXMLUnstructuredGridReader>::New();
  reader->SetFileName(path.c_str());
  reader->Update();
  vtkUnstructuredGrid* read = reader->GetOutput();
  ASSERT_EQ(read->GetNumberOfCells(), 1);
  EXPECT_EQ(read->GetCellType(0), VTK_TETRA);
  EXPECT_DOUBLE_EQ(read->GetPoint(2)[1], 20.0);
  EXPECT_EQ(field(*read, "SPACE"), "LPS");
  EXPECT_EQ(field(*read, "UNITS"), "mm");
}

TEST_F(MeshFiles, StlHeaderSaysLpsAndMm) {
  const fs::path path = dir_ / "surface.stl";
  write_surface_stl(tetrahedron_surface(), path.string());
  std::ifstream in(path, std::ios::binary);
  std::string header(80, '\0');
  in.read(header.data(), 80);
  EXPECT_NE(header.find("SPACE=LPS"), std::string::npos);
  EXPECT_NE(header.find("UNITS=mm"), std::string::npos);
  auto reader = vtkSmartPointer<vtkSTLReader>::New();
  reader->SetFileName(path.c_str());
  reader->Update();
  EXPECT_EQ(reader->GetOutput()->GetNumberOfPolys(), 4);
}

TEST_F(MeshFiles, CollectionIndexesTheFramesInTimeOrder) {
  const fs::path path = dir_ / "frames.pvd";
  write_collection_pvd({{0.0, "frame_00000.vtp"}, {1.0 / 60.0, "frame_00001.vtp"}}, path.string());
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  const std::string pvd = text.str();
  EXPECT_NE(pvd.find("<VTKFile type=\"Collection\""), std::string::npos);
  const auto first = pvd.find("timestep=\"0.000000\" file=\"frame_00000.vtp\"");
  const auto second = pvd.find("timestep=\"0.016667\" file=\"frame_00001.vtp\"");
  ASSERT_NE(first, std::string::npos);
  ASSERT_NE(second, std::string::npos);
  EXPECT_LT(first, second);
}

TEST_F(MeshFiles, AnUnwritableDirectoryIsAnErrorNamingThePath) {
  const std::string path = (dir_ / "missing" / "surface.vtp").string();
  try {
    write_surface_vtp(tetrahedron_surface(), path);
    FAIL() << "expected an error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace organsim::mesh_io

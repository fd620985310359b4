// `organsim export`: the model's surface, tetrahedra and beam tables back out,
// readable by VTK (what 3D Slicer and ParaView use), in millimetres, in the
// model file's order; bad input writes nothing.
#include <gtest/gtest.h>

#include <vtkNew.h>
#include <vtkOBJReader.h>
#include <vtkPolyData.h>
#include <vtkSTLReader.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLPolyDataReader.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>

#include "cli_fixture.h"
#include "organsim/model/model_file.h"
#include "test_models.h"

namespace organsim {
namespace {

using namespace cli::testing;

template <typename Reader>
vtkSmartPointer<vtkPolyData> read_surface(const std::filesystem::path& path) {
  vtkNew<Reader> reader;
  reader->SetFileName(path.string().c_str());
  reader->Update();
  return reader->GetOutput();
}

TEST_F(Cli, ExportWritesTheSurfaceTetrahedraAndABeamTable) {
  const model::OrganModel model = testing::make_cylinder_model({});
  const std::string path = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(model, path);
  ASSERT_FALSE(model.tetrahedra.empty());
  const std::size_t vertices = model.surface_vertices.size(), triangles = model.surface_triangles.size();

  for (const char* extension : {"vtp", "stl", "obj"}) {
    const std::filesystem::path surface = dir_ / (std::string("surface.") + extension);
    const CommandRun run = run_organsim("export " + path + " --surface " + surface.string(), dir_);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    vtkSmartPointer<vtkPolyData> read = extension == std::string("vtp")   ? read_surface<vtkXMLPolyDataReader>(surface)
                                        : extension == std::string("stl") ? read_surface<vtkSTLReader>(surface)
                                                                          : read_surface<vtkOBJReader>(surface);
    ASSERT_NE(read, nullptr) << extension;
    EXPECT_EQ(static_cast<std::size_t>(read->GetNumberOfPolys()), triangles) << extension;
    if (extension == std::string("stl")) continue;  // STL repeats each vertex per triangle
    ASSERT_EQ(static_cast<std::size_t>(read->GetNumberOfPoints()), vertices) << extension;
    // The file's vertex order, in millimetres (the model is in metres).
    for (std::size_t v : {std::size_t{0}, vertices / 2, vertices - 1}) {
      double p[3];
      read->GetPoint(static_cast<vtkIdType>(v), p);
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(p[k], 1e3 * model.surface_vertices[v][k], 1e-4) << extension << " " << v;
    }
  }

  const std::filesystem::path tetrahedra = dir_ / "tetrahedra.vtu", beam = dir_ / "beam.csv";
  const CommandRun run =
      run_organsim("export " + path + " --tetrahedra " + tetrahedra.string() + " --beam 7 " + beam.string(), dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  vtkNew<vtkXMLUnstructuredGridReader> reader;
  reader->SetFileName(tetrahedra.string().c_str());
  reader->Update();
  EXPECT_EQ(static_cast<std::size_t>(reader->GetOutput()->GetNumberOfCells()), model.tetrahedra.size());
  EXPECT_EQ(static_cast<std::size_t>(reader->GetOutput()->GetNumberOfPoints()), model.volume_vertices.size());

  std::ifstream csv(beam);
  std::string header, line;
  std::getline(csv, header);
  EXPECT_EQ(header, "station,t,area_m2,i_yy_m4,i_zz_m4,i_yz_m4,torsion_j_m4,centroid_y_m,centroid_z_m");
  std::uint32_t rows = 0;
  while (std::getline(csv, line)) {
    std::istringstream row(line);
    std::string cell;
    std::getline(row, cell, ',');
    EXPECT_EQ(std::stoul(cell), rows);
    std::getline(row, cell, ',');
    std::getline(row, cell, ',');  // the area, exactly as in the model
    EXPECT_DOUBLE_EQ(std::stod(cell), model.beams.at(7, rows).area);
    ++rows;
  }
  EXPECT_EQ(rows, model.beams.stations_per_beam);
}

TEST_F(Cli, ExportBadInputFailsWithOneLineAndWritesNothing) {
  const std::string path = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), path);
  const std::filesystem::path out = dir_ / "surface.vtp";
  for (const std::string& arguments :
       {"export " + path + " --surface " + (dir_ / "surface.ply").string(),
        "export " + path + " --surface " + out.string() + " --beam 999999 " + (dir_ / "b.csv").string(),
        "export " + path + " --surface " + out.string() + " --beam x " + (dir_ / "b.csv").string(),
        "export " + path + " --surface " + out.string() + " --tetrahedra " + (dir_ / "t.vtk").string(),
        "export " + (dir_ / "missing.organ").string() + " --surface " + out.string()}) {
    const CommandRun run = run_organsim(arguments + " --quiet", dir_);
    EXPECT_EQ(run.exit_code, 1) << arguments << "\n" << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << arguments << ": " << run.err;
    EXPECT_FALSE(std::filesystem::exists(out)) << arguments;
  }
  const CommandRun nothing = run_organsim("export " + path, dir_);
  EXPECT_EQ(nothing.exit_code, 2) << nothing.err;
}

}  // namespace
}  // namespace organsim

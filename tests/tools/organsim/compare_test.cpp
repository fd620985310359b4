// `organsim compare`: every model pressed the same way and measured against a
// reference — the JSON shape, the reference against itself, the files for
// ParaView, and bad input.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <vtkDataArray.h>
#include <vtkNew.h>
#include <vtkImageData.h>
#include <vtkPNGReader.h>
#include <vtkPointData.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "cli_fixture.h"
#include "organsim/model/model_file.h"
#include "test_models.h"

namespace organsim {
namespace {

using namespace cli::testing;

// The helper cylinder (radius 30 mm, 150 mm along x) clamped over its x = 0
// cap for the FEM models, pressed 5 mm down at the far cap's rim and held
// there (--friction inf: the press is 45° from the rim's normal, outside the
// friction cone, and would slip).
constexpr const char* kPress = " --tool 150,0,30/0,0,-5 --fixed-radius 31 --friction inf";

TEST_F(Cli, CompareMeasuresEveryModelAgainstTheReference) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const CommandRun run = run_organsim("compare " + model + kPress + " --json --out " + (dir_ / "out").string(), dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["reference"], "psh");
  const std::vector<std::string> names = {"beam", "springs", "linear", "corotational", "stvk", "psh"};
  for (const std::string& name : names) {
    ASSERT_TRUE(j["models"].contains(name)) << name;
    const nlohmann::json& m = j["models"][name];
    for (const char* key : {"mean_difference", "max_difference", "mean_difference_per_axis", "max_difference_per_axis",
                            "paper_mean_difference", "paper_max_difference", "forces_n", "volume_change_percent",
                            "frame_time_ms", "force_tick_us"})
      EXPECT_TRUE(m.contains(key)) << name << ": " << key;
    EXPECT_EQ(m["mean_difference_per_axis"].size(), 3u) << name;
    // Ogata et al.'s Table 5 measure: the per-axis means' average and the largest component.
    const nlohmann::json& axis_mean = m["mean_difference_per_axis"];
    EXPECT_NEAR(m["paper_mean_difference"].get<double>(),
                (axis_mean[0].get<double>() + axis_mean[1].get<double>() + axis_mean[2].get<double>()) / 3, 1e-15)
        << name;
    const nlohmann::json& axis_max = m["max_difference_per_axis"];
    EXPECT_EQ(m["paper_max_difference"].get<double>(),
              std::max({axis_max[0].get<double>(), axis_max[1].get<double>(), axis_max[2].get<double>()}))
        << name;
    EXPECT_GE(m["paper_max_difference"].get<double>(), m["paper_mean_difference"].get<double>()) << name;
    ASSERT_EQ(m["forces_n"].size(), 1u) << name;                // one per tool
    EXPECT_GT(m["forces_n"][0][2].get<double>(), 0.0) << name;  // pressed along −z: pushed back along +z
    EXPECT_GT(m["frame_time_ms"].get<double>(), 0.0) << name;
    EXPECT_GT(m["force_tick_us"].get<double>(), 0.0) << name;
    // exp(|ln(|F| / |F_ref|)|) for one tool: 1 for the reference itself.
    const double ratio = std::hypot(m["forces_n"][0][0].get<double>(), m["forces_n"][0][1].get<double>(),
                                    m["forces_n"][0][2].get<double>()) /
                         std::hypot(j["models"]["psh"]["forces_n"][0][0].get<double>(),
                                    j["models"]["psh"]["forces_n"][0][1].get<double>(),
                                    j["models"]["psh"]["forces_n"][0][2].get<double>());
    EXPECT_NEAR(m["force_factor"].get<double>(), std::max(ratio, 1.0 / ratio), 1e-9) << name;
    if (name == "psh") continue;
    // Every other model deforms differently from the nearly incompressible FEM,
    // by less than the 5 mm press (3.6 % of this bounding box's diagonal).
    EXPECT_GT(m["mean_difference"].get<double>(), 0.0) << name;
    EXPECT_LE(m["mean_difference"].get<double>(), m["max_difference"].get<double>()) << name;
    EXPECT_LT(m["max_difference"].get<double>(), 0.036) << name;
  }
  const nlohmann::json& self = j["models"]["psh"];
  EXPECT_EQ(self["mean_difference"].get<double>(), 0.0);
  EXPECT_EQ(self["max_difference"].get<double>(), 0.0);
  for (double axis : self["mean_difference_per_axis"]) EXPECT_EQ(axis, 0.0);
  EXPECT_EQ(self["paper_mean_difference"].get<double>(), 0.0);
  EXPECT_EQ(self["paper_max_difference"].get<double>(), 0.0);
  // The FEM models share the reference's clamp and contact: they are closer to
  // it than the multi-beam model, whose stiffness comes from the beam sections.
  for (const char* fem : {"linear", "corotational", "stvk"})
    EXPECT_LT(j["models"][fem]["mean_difference"].get<double>(), j["models"]["beam"]["mean_difference"].get<double>())
        << fem;

  // One file per model, readable by VTK, with the displacement and the
  // difference from the reference (zero for the reference itself).
  for (const std::string& name : names) {
    vtkNew<vtkXMLUnstructuredGridReader> reader;
    reader->SetFileName((dir_ / "out" / (name + ".vtu")).string().c_str());
    reader->Update();
    vtkUnstructuredGrid* grid = reader->GetOutput();
    ASSERT_GT(grid->GetNumberOfPoints(), 100) << name;
    ASSERT_GT(grid->GetNumberOfCells(), 100) << name;
    vtkDataArray* displacement = grid->GetPointData()->GetArray("displacement");
    vtkDataArray* difference = grid->GetPointData()->GetArray("difference");
    ASSERT_NE(displacement, nullptr) << name;
    ASSERT_NE(difference, nullptr) << name;
    double largest_difference = 0.0;
    for (vtkIdType p = 0; p < grid->GetNumberOfPoints(); ++p)
      for (int k = 0; k < 3; ++k)
        largest_difference = std::max(largest_difference, std::abs(difference->GetComponent(p, k)));
    if (name == "psh")
      EXPECT_EQ(largest_difference, 0.0);
    else
      EXPECT_GT(largest_difference, 0.0) << name;
    EXPECT_NEAR(displacement->GetRange(2)[0], -5.0, 1.0) << name;  // mm: the press
  }
}

// With --volume-springs the spring network holds the organ where the FEM
// models do (the clamp) instead of pinning every surface vertex to an anchor
// of its own: the cantilever pressed at its free end then bends as the
// reference does, where the surface network only dents under the tool.
TEST_F(Cli, CompareVolumeSpringsBendAboutTheClampAsTheReferenceDoes) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  double difference[2] = {0.0, 0.0};  // of the bounding box: 1.04 % and 0.14 % when written
  for (int volume = 0; volume < 2; ++volume) {
    const CommandRun run = run_organsim(
        "compare " + model + kPress + " --models springs,psh --json" + (volume ? " --volume-springs" : ""), dir_);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const nlohmann::json j = nlohmann::json::parse(run.out);
    difference[volume] = j["models"]["springs"]["mean_difference"].get<double>();
  }
  EXPECT_LT(difference[1], 0.5 * difference[0]) << "surface network " << difference[0];
}

TEST_F(Cli, CompareDrawsItsPlotsUnderAVirtualDisplay) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const fs::path out = dir_ / "plots";
  const CommandRun run = run_organsim_with_prefix(
      "xvfb-run -a -s '-screen 0 1280x1024x24' ",
      "compare " + model + kPress + " --models beam,linear --sweep 2 --json --out " + out.string(), dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  ASSERT_EQ(j["plots"].size(), 2u);
  for (const char* name : {"differences.png", "force_depth.png"}) {
    vtkNew<vtkPNGReader> reader;
    reader->SetFileName((out / name).string().c_str());
    reader->Update();
    int size[3] = {};
    reader->GetOutput()->GetDimensions(size);
    EXPECT_EQ(size[0], 800) << name;
    EXPECT_EQ(size[1], 500) << name;
  }
  // The tetrahedra of the models that move them, with both fields.
  for (const char* name : {"beam", "linear", "psh"}) {
    vtkNew<vtkXMLUnstructuredGridReader> reader;
    reader->SetFileName((out / (std::string(name) + "_tetrahedra.vtu")).string().c_str());
    reader->Update();
    EXPECT_GT(reader->GetOutput()->GetNumberOfCells(), 100) << name;
    EXPECT_NE(reader->GetOutput()->GetPointData()->GetArray("difference"), nullptr) << name;
  }
  EXPECT_EQ(j["models"]["beam"]["compared_on"], "tetrahedral nodes");
}

TEST_F(Cli, CompareTextTableAndAChosenReference) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const CommandRun run =
      run_organsim("compare " + model + kPress + " --models beam,linear --reference corotational", dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  for (const char* expected : {"against corotational", "| beam ", "| linear ", "| corotational ", "tool 1 |F| (N)"})
    EXPECT_NE(run.out.find(expected), std::string::npos) << expected << "\n" << run.out;
  EXPECT_EQ(run.out.find("| psh "), std::string::npos) << run.out;  // only the models asked for and the reference
}

TEST_F(Cli, CompareBadInputFailsWithOneLine) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const std::vector<std::pair<std::string, int>> cases = {
      {" --tool 150,0,30/0,0,-5 --models beam,fem", 2},        // unknown model name
      {" --models beam,linear", 2},                            // no tool
      {" --tool 500,500,500/0,0,-5 --models beam,linear", 1},  // a tool far outside the organ
      {" --tool 150,0,30/0,0,-5 --models beam,linear", 1},     // the default 10 mm clamp holds one node here
      {" --tool 150,0,30/0,0,-5 --reference fem", 2},
  };
  for (const auto& [arguments, code] : cases) {
    const CommandRun run = run_organsim("compare " + model + arguments + " --quiet", dir_);
    EXPECT_EQ(run.exit_code, code) << arguments << ": " << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << arguments << ": " << run.err;
  }
}

}  // namespace
}  // namespace organsim

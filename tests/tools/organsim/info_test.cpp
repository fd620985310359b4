// `organsim info`: the JSON keys, the text report, and damaged or missing
// model files.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>
#include <utility>

#include "cli_fixture.h"
#include "organsim/model/model_file.h"
#include "test_models.h"

namespace organsim {
namespace {

using namespace cli::testing;

TEST_F(Cli, InfoJsonIsOneParsableObjectWithTheDocumentedKeys) {
  testing::CylinderSpec spec;
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model(spec), model);
  const CommandRun run = run_organsim("info " + model + " --json --beam 5", dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["units"], "SI");
  EXPECT_EQ(j["coordinate_frame"], "LPS");
  EXPECT_EQ(j["format_version"],
            std::to_string(model::kModelFormatVersion.major) + "." + std::to_string(model::kModelFormatVersion.minor));
  EXPECT_EQ(j["counts"]["surface_vertices"], (spec.rings + 1) * spec.segments + 2);
  EXPECT_EQ(j["counts"]["beam_stations"], 20);
  const double polygon = 0.5 * spec.segments * spec.radius * spec.radius * std::sin(2 * M_PI / spec.segments);
  EXPECT_NEAR(j["volume_m3"]["tetrahedra"].get<double>(), polygon * spec.length, 1e-12);
  EXPECT_NEAR(j["bounding_box_m"]["size"][0].get<double>(), spec.length, 1e-12);
  EXPECT_DOUBLE_EQ(j["material"]["young_modulus_pa"].get<double>(), 5000.0);
  EXPECT_EQ(j["provenance"]["parameters"]["shape"], "cylinder");
  EXPECT_EQ(j["beam"]["vertex"], 5);
  EXPECT_EQ(j["beam"]["stations"].size(), 20u);
  EXPECT_GT(j["beam"]["stations"][10]["area_m2"].get<double>(), 0.0);
  EXPECT_EQ(j["sections"].size(), 9u);
  EXPECT_TRUE(j["site_compliance"].is_null());

  // With site data and the cylinder side's curvatures (1/r, 0): the tip's
  // Hertz radius R/√(1 + R/r) everywhere.
  model::OrganModel with_sites = testing::make_cylinder_model(spec);
  testing::add_uniform_site_compliance(with_sites, 0.02);
  with_sites.sites.curvature.assign(with_sites.surface_vertices.size(), {1 / spec.radius, 0.0});
  with_sites.sites.pull_curve = {{{0.0, 1.0}}, {{0.012, 3.25}}};
  with_sites.sites.pull_tip_radius = 0.0025;
  model::write_organ_model_file(with_sites, model);
  const CommandRun sites = run_organsim("info " + model + " --json", dir_);
  ASSERT_EQ(sites.exit_code, 0) << sites.err;
  const nlohmann::json s = nlohmann::json::parse(sites.out)["site_compliance"];
  EXPECT_NEAR(s["hertz_radius_m_at_2_5_mm_tip"]["median"].get<double>(), 0.0025 / std::sqrt(1 + 0.0025 / spec.radius),
              1e-15);
  EXPECT_GT(s["normal_stiffness_n_per_m_at_2_5_mm_tip"]["median"].get<double>(), 0.0);
  ASSERT_EQ(s["pull_curve"].size(), 2u);
  EXPECT_DOUBLE_EQ(s["pull_curve"][1]["drawn_m"].get<double>(), 0.012);
  EXPECT_DOUBLE_EQ(s["pull_curve"][1]["softening"].get<double>(), 3.25);
  EXPECT_DOUBLE_EQ(s["pull_curve_tip_radius_m"].get<double>(), 0.0025);
  const std::string text = run_organsim("info " + model, dir_).out;
  EXPECT_NE(text.find("a 2.5 mm tip's Hertz radius 2.40 (p10)"), std::string::npos) << text;
  EXPECT_NE(
      text.find("pull curve      a held patch's softening by the distance drawn: 0 mm x 1, 12 mm x 3.25 (tip 2.5 mm)"),
      std::string::npos)
      << text;
}

TEST_F(Cli, InfoTextNamesUnitsAndVolume) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const CommandRun run = run_organsim("info " + model, dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("units           SI"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("mL) from the tetrahedra"), std::string::npos) << run.out;
}

TEST_F(Cli, InfoOnGarbageOrDamagedFilesFailsWithOneLineAndLeavesNothing) {
  const fs::path garbage = dir_ / "garbage.organ";
  std::ofstream(garbage) << "this is not a model";
  const fs::path model = dir_ / "damaged.organ";
  auto bytes = model::serialize_organ_model(testing::make_cylinder_model({}));
  bytes[bytes.size() / 2] ^= 0x20;
  std::ofstream(model, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  const fs::path truncated = dir_ / "truncated.organ";
  std::ofstream(truncated, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), 100);
  for (const auto& [path, problem] : {std::pair{garbage, "wrong magic bytes"},
                                      {model, "checksum mismatch"},
                                      {truncated, "truncated"},
                                      {dir_ / "missing.organ", "cannot open"}}) {
    const std::size_t files_before = files_in_dir();
    const CommandRun run = run_organsim("info " + path.string(), dir_);
    EXPECT_EQ(run.exit_code, 1) << run.err;
    EXPECT_TRUE(run.out.empty());
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
    EXPECT_NE(run.err.find(problem), std::string::npos) << run.err;
    EXPECT_NE(run.err.find(path.string()), std::string::npos) << run.err;
    EXPECT_EQ(files_in_dir(), files_before);
  }
}

TEST_F(Cli, InfoBeamOutOfRange) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const CommandRun run = run_organsim("info " + model + " --beam 100000", dir_);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("--beam 100000 is out of range"), std::string::npos) << run.err;
}

}  // namespace
}  // namespace organsim

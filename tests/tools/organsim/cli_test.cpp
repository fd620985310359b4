// The `organsim` program as users and scripts see it: exit codes, one-line
// errors, JSON output, no files left behind.
#include <gtest/gtest.h>
#include <Eigen/Core>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include <sys/wait.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <algorithm>
#include <vector>

#include "organsim/model/model_file.h"
#include "organsim/pipeline/image_io.h"
#include "organsim/pipeline/phantom.h"
#include "test_models.h"

namespace organsim {
namespace {

namespace fs = std::filesystem;

struct CommandRun {
  int exit_code = -1;
  std::string out;
  std::string err;
};

/// Runs the organsim binary with `arguments` (already shell-quoted), after
/// `prefix` (e.g. a wrapper command).
CommandRun run_organsim_with_prefix(const std::string& prefix, const std::string& arguments, const fs::path& dir) {
  const fs::path err_file = dir / "stderr.txt";
  const std::string command = prefix + std::string(ORGANSIM_EXECUTABLE) + " " + arguments + " 2>" + err_file.string();
  CommandRun run;
  FILE* pipe = ::popen(command.c_str(), "r");
  std::array<char, 4096> buffer{};
  std::size_t n;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0) run.out.append(buffer.data(), n);
  const int status = ::pclose(pipe);
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  std::ifstream err(err_file);
  run.err.assign(std::istreambuf_iterator<char>(err), {});
  fs::remove(err_file);
  return run;
}

CommandRun run_organsim(const std::string& arguments, const fs::path& dir) { return run_organsim_with_prefix("", arguments, dir); }

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("organsim_cli_" + std::string(
        ::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::size_t files_in_dir() const { return static_cast<std::size_t>(std::distance(fs::directory_iterator(dir_), {})); }
  fs::path dir_;
};

TEST_F(Cli, InfoJsonIsOneParsableObjectWithTheDocumentedKeys) {
  testing::CylinderSpec spec;
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model(spec), model);
  const CommandRun run = run_organsim("info " + model + " --json --beam 5", dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["units"], "SI");
  EXPECT_EQ(j["coordinate_frame"], "LPS");
  EXPECT_EQ(j["format_version"], "1.0");
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
  std::ofstream(model, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()),
                                               static_cast<std::streamsize>(bytes.size()));
  const fs::path truncated = dir_ / "truncated.organ";
  std::ofstream(truncated, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()), 100);
  for (const auto& [path, problem] : {std::pair{garbage, "wrong magic bytes"}, {model, "checksum mismatch"},
                                      {truncated, "truncated"}, {dir_ / "missing.organ", "cannot open"}}) {
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

TEST_F(Cli, PhantomIsByteIdenticalForTheSameSeedInEveryFormat) {
  for (const char* extension : {".nii.gz", ".nrrd", ".mha"}) {
    const std::string a = (dir_ / (std::string("a") + extension)).string();
    const std::string b = (dir_ / (std::string("b") + extension)).string();
    const std::string options = " --size 48,40,24 --spacing 8,8,8 --seed 7";
    const CommandRun first = run_organsim("phantom -o " + a + " --mask " + (dir_ / "ma.nii.gz").string() + options, dir_);
    ASSERT_EQ(first.exit_code, 0) << first.err;
    ASSERT_EQ(run_organsim("phantom -o " + b + options, dir_).exit_code, 0);
    std::ifstream fa(a, std::ios::binary), fb(b, std::ios::binary);
    const std::string da((std::istreambuf_iterator<char>(fa)), {}), db((std::istreambuf_iterator<char>(fb)), {});
    EXPECT_GT(da.size(), 1000u);
    EXPECT_EQ(da, db) << extension;
    EXPECT_NE(first.out.find("fixed point"), std::string::npos);
  }
}

TEST_F(Cli, PhantomWritesADicomSeriesWithOneFilePerSlice) {
  const CommandRun run = run_organsim("phantom -o " + (dir_ / "ct.nii.gz").string() + " --dicom " +
                                   (dir_ / "dicom").string() + " --size 32,32,20 --spacing 12,12,10",
                               dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(run.err.empty()) << run.err;
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_ / "dicom"), {}), 20);
  const CommandRun again = run_organsim("phantom -o " + (dir_ / "ct2.nii.gz").string() + " --dicom " +
                                     (dir_ / "dicom").string() + " --size 32,32,20",
                                 dir_);
  EXPECT_EQ(again.exit_code, 1);
  EXPECT_NE(again.err.find("not an empty directory"), std::string::npos) << again.err;
}

TEST_F(Cli, PhantomRejectsBadOptionsAndUnknownExtensions) {
  const CommandRun small = run_organsim("phantom -o " + (dir_ / "ct.nii.gz").string() + " --size 8,8,8", dir_);
  EXPECT_EQ(small.exit_code, 1);
  EXPECT_NE(small.err.find("at least 16 voxels"), std::string::npos) << small.err;
  const CommandRun extension = run_organsim("phantom -o " + (dir_ / "ct.png").string() + " --size 16,16,16", dir_);
  EXPECT_EQ(extension.exit_code, 1);
  EXPECT_NE(extension.err.find("unsupported extension"), std::string::npos) << extension.err;
  EXPECT_EQ(files_in_dir(), 0u);
}

const fs::path kSamples = ORGANSIM_DATA_SAMPLES;

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

/// Small, quick bake options for the shipped phantom.
std::string quick_phantom_bake(const fs::path& output) {
  return (kSamples / "phantom_ct.nii.gz").string() + " --seed -65,5,0 --surface-vertices 800 --tet-size 12 " +
         "--stations 8 --section-samples 32 -o " + output.string();
}

TEST_F(Cli, BakeJsonReportHasTheDocumentedKeysAndTheModelLoads) {
  const fs::path model = dir_ / "liver.organ";
  const CommandRun run = run_organsim("bake " + quick_phantom_bake(model) + " --json", dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json j = nlohmann::json::parse(run.out);  // one object, nothing else on stdout
  EXPECT_EQ(j["model"], model.string());
  EXPECT_EQ(j["model_bytes"].get<std::uintmax_t>(), fs::file_size(model));
  EXPECT_EQ(j["input_sha256"].get<std::string>().size(), 64u);
  EXPECT_EQ(j["image"]["size"], nlohmann::json::array({128, 104, 64}));
  EXPECT_GT(j["segmentation"]["voxels"].get<int>(), 50000);
  EXPECT_EQ(j["fixed_point"]["source"], "deepest interior point");
  EXPECT_GT(j["fixed_point"]["depth_mm"].get<double>(), 10.0);
  EXPECT_NEAR(j["surface"]["vertices"].get<double>(), 800.0, 80.0);
  EXPECT_NEAR(j["tetrahedra"]["volume_ml"].get<double>(), j["segmentation"]["volume_ml"].get<double>(),
              0.03 * j["segmentation"]["volume_ml"].get<double>());
  for (const char* key : {"count", "vertices", "min_dihedral_deg", "max_dihedral_deg", "max_radius_edge_ratio",
                          "mean_radius_edge_ratio", "min_volume_mm3"})
    EXPECT_TRUE(j["tetrahedra"].contains(key)) << key;
  EXPECT_EQ(j["beams"]["stations"], 8);
  for (const char* stage : {"read CT", "segment", "fixed point", "surface", "tetrahedra", "beam tables", "assemble"})
    EXPECT_TRUE(j["seconds"]["stages"].contains(stage)) << stage;
  // Progress went to stderr, one line per stage start and end (not a terminal here).
  EXPECT_NE(run.err.find("organsim bake: tetrahedra done in"), std::string::npos) << run.err;
  const CommandRun info = run_organsim("info " + model.string() + " --json", dir_);
  ASSERT_EQ(info.exit_code, 0) << info.err;
  EXPECT_EQ(nlohmann::json::parse(info.out)["counts"]["beam_stations"], 8);
}

TEST_F(Cli, BakeIsByteIdenticalAcrossRuns) {
  ASSERT_EQ(run_organsim("bake " + quick_phantom_bake(dir_ / "a.organ"), dir_).exit_code, 0);
  ASSERT_EQ(run_organsim("bake " + quick_phantom_bake(dir_ / "b.organ") + " --threads 1", dir_).exit_code, 0);
  EXPECT_TRUE(read_bytes(dir_ / "a.organ") == read_bytes(dir_ / "b.organ"));
}

TEST_F(Cli, NoPatientTagReachesTheModelTheReportOrTheLog) {
  // A DICOM series with a known patient name, ID and birth date.
  const pipeline::Phantom phantom = pipeline::make_phantom(pipeline::PhantomOptions{});
  pipeline::DicomSeriesInfo info;
  info.patient_name = "DOE^JANE^QUINCY";
  info.patient_id = "MRN-4711-0815";
  pipeline::write_dicom_series(*phantom.ct, (dir_ / "dicom").string(), info);
  ASSERT_NE(read_bytes(fs::directory_iterator(dir_ / "dicom")->path()).find("DOE^JANE"), std::string::npos);

  const fs::path model = dir_ / "liver.organ";
  const std::string bake = "bake " + (dir_ / "dicom").string() +
                           " --seed -65,5,0 --surface-vertices 800 --tet-size 12 --stations 8 --section-samples 32 -o " +
                           model.string() + " --intermediates " + (dir_ / "inspect").string();
  for (const std::string& extra : {std::string(), std::string(" --json")}) {
    const CommandRun run = run_organsim(bake + extra, dir_);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    for (const std::string& text : {run.out, run.err, read_bytes(model)}) {
      EXPECT_EQ(text.find("DOE"), std::string::npos);
      EXPECT_EQ(text.find("JANE"), std::string::npos);
      EXPECT_EQ(text.find("4711"), std::string::npos);
    }
  }
  for (const auto& entry : fs::directory_iterator(dir_ / "inspect")) {
    const std::string bytes = read_bytes(entry.path());
    EXPECT_EQ(bytes.find("DOE"), std::string::npos) << entry.path();
    EXPECT_EQ(bytes.find("4711"), std::string::npos) << entry.path();
  }
}

TEST_F(Cli, BakeBadInputsFailWithOneLineAndLeaveNoModel) {
  const fs::path model = dir_ / "out" / "liver.organ";
  fs::create_directories(model.parent_path());
  const std::string ct = (kSamples / "phantom_ct.nii.gz").string();
  const std::string quick = " --surface-vertices 800 --tet-size 12 --stations 8 --section-samples 32 -o " + model.string();
  const pipeline::Phantom phantom = pipeline::make_phantom(pipeline::PhantomOptions{});
  pipeline::DicomSeriesInfo first, second;
  first.uid_seed = 1, second.uid_seed = 2;
  second.series_description = "second series";
  pipeline::write_dicom_series(*phantom.ct, (dir_ / "two_series").string(), first);
  pipeline::write_dicom_series(*phantom.ct, (dir_ / "second").string(), second);
  for (const auto& entry : fs::directory_iterator(dir_ / "second"))
    fs::rename(entry.path(), dir_ / "two_series" / ("second_" + entry.path().filename().string()));
  {
    std::ofstream text(dir_ / "notes.nii.gz");
    text << "not an image";
  }
  const std::vector<std::pair<std::string, std::string>> cases = {
      {dir_.string() + "/missing.nii.gz --seed 0,0,0", "missing.nii.gz"},
      {(dir_ / "notes.nii.gz").string() + " --seed 0,0,0", "notes.nii.gz"},
      {(dir_ / "two_series").string() + " --seed -65,5,0", "second series"},
      {ct + " --seed 900,0,0", "outside the volume"},
      {ct + " --seed-voxel 500,3,3", "outside the volume"},
      {ct + " --seed 0,-100,0", "outside the window"},
      {ct, "no segmentation"},
      {ct + " --label " + (kSamples / "phantom_liver_mask.nii.gz").string() + " --label-value 3", "label value 3"},
      {ct + " --label " + (kSamples / "real_ct_totalseg" / "liver_mask_ct.nii.gz").string(), "does not match"},
      {ct + " --seed -65,5,0 --fixed-point 150,150,90", "outside the organ"},
      {ct + " --seed -65,5,0 --poisson-ratio 0.5", "--poisson-ratio"},
      {ct + " --seed -65,5,0 --facet-distance 0", "--facet-distance"},
  };
  for (const auto& [arguments, fragment] : cases) {
    const CommandRun run = run_organsim("bake " + arguments + quick, dir_);
    EXPECT_EQ(run.exit_code, 1) << arguments;
    const std::string last_line = run.err.substr(run.err.rfind("organsim bake: error: ") == std::string::npos
                                                     ? 0
                                                     : run.err.rfind("organsim bake: error: "));
    EXPECT_NE(last_line.find(fragment), std::string::npos) << arguments << "\n" << run.err;
    EXPECT_EQ(std::count(last_line.begin(), last_line.end(), '\n'), 1) << run.err;
    EXPECT_FALSE(fs::exists(model)) << arguments;
    EXPECT_TRUE(fs::is_empty(model.parent_path())) << arguments;  // no temporary file either
  }
}

// A solid cylinder CT: radius 25 mm, along x from x = 0 to x = 150 mm, 1 mm
// voxels, tissue 60 HU in −100 HU fat; and its label map.
void write_cylinder_ct(const fs::path& ct_path, const fs::path& label_path) {
  constexpr double kRadius = 25.0, kLength = 150.0;
  pipeline::CtImage::Pointer ct = pipeline::CtImage::New();
  pipeline::MaskImage::Pointer label = pipeline::MaskImage::New();
  pipeline::CtImage::RegionType region;
  region.SetSize({170, 70, 70});
  ct->SetRegions(region);
  label->SetRegions(region);
  const double origin[3] = {-10.0, -34.5, -34.5};
  ct->SetOrigin(origin);
  label->SetOrigin(origin);
  ct->Allocate();
  label->Allocate();
  for (itk::IndexValueType k = 0; k < 70; ++k)
    for (itk::IndexValueType j = 0; j < 70; ++j)
      for (itk::IndexValueType i = 0; i < 170; ++i) {
        const double x = origin[0] + i, y = origin[1] + j, z = origin[2] + k;
        const bool inside = x >= 0.0 && x <= kLength && y * y + z * z <= kRadius * kRadius;
        ct->SetPixel({i, j, k}, static_cast<std::int16_t>(inside ? 60 : -100));
        label->SetPixel({i, j, k}, inside ? 1 : 0);
      }
  pipeline::write_ct_image(*ct, ct_path.string());
  pipeline::write_mask_image(*label, label_path.string());
}

TEST_F(Cli, PokeABakedCylinderGivesTheCantileverForces) {
  // CT → bake (clamped at the centre of the x = 0 cap) → poke the far cap:
  // transverse 3EIδ/L³ and axial EAδ/L of a circular beam, within a few percent
  // (the voxelized, smoothed surface is the only approximation).
  const fs::path ct = dir_ / "cylinder_ct.nii.gz", label = dir_ / "cylinder_label.nii.gz";
  write_cylinder_ct(ct, label);
  const std::string model = (dir_ / "cylinder.organ").string();
  const CommandRun bake = run_organsim("bake " + ct.string() + " --label " + label.string() +
                                           " --fixed-point 0,0,0 --surface-vertices 4000 -o " + model,
                                       dir_);
  ASSERT_EQ(bake.exit_code, 0) << bake.err;

  const double e = 5000.0, radius = 0.025, delta = 0.005;
  const double area = M_PI * radius * radius, inertia = M_PI * std::pow(radius, 4) / 4.0;
  const CommandRun transverse = run_organsim("poke " + model + " --tool 151,0,0/0,5,0 --json", dir_);
  ASSERT_EQ(transverse.exit_code, 0) << transverse.err;
  const nlohmann::json t = nlohmann::json::parse(transverse.out);
  const double length = t["tools"][0]["beam_length_mm"].get<double>() * 1e-3;
  EXPECT_NEAR(length, 0.150, 0.002);
  const double expected_transverse = 3.0 * e * inertia * delta / std::pow(length, 3);
  EXPECT_NEAR(-t["tools"][0]["force_n"][1].get<double>(), expected_transverse, 0.04 * expected_transverse);
  // The action point lies inside a triangle, so no vertex moves the full 5 mm.
  EXPECT_LE(t["organ"]["max_displacement_mm"].get<double>(), 5.0 + 1e-9);
  EXPECT_GT(t["organ"]["max_displacement_mm"].get<double>(), 3.0);

  const CommandRun axial = run_organsim("poke " + model + " --tool 151,0,0/-5,0,0 --json", dir_);
  ASSERT_EQ(axial.exit_code, 0) << axial.err;
  const nlohmann::json a = nlohmann::json::parse(axial.out);
  const double expected_axial = e * area * delta / length;
  EXPECT_NEAR(a["tools"][0]["force_n"][0].get<double>(), expected_axial, 0.04 * expected_axial);
  EXPECT_LT(std::abs(a["tools"][0]["force_n"][1].get<double>()), 0.05 * expected_axial);
  std::printf("baked cylinder: transverse force %+.2f %%, axial force %+.2f %% from the analytic values\n",
              100.0 * (-t["tools"][0]["force_n"][1].get<double>() / expected_transverse - 1.0),
              100.0 * (a["tools"][0]["force_n"][0].get<double>() / expected_axial - 1.0));
}

TEST_F(Cli, PokeJsonHasTheDocumentedKeysAndWritesTheDeformedSurface) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const std::string out = (dir_ / "deformed.vtp").string();
  const CommandRun run =
      run_organsim("poke " + model + " --tool 150,0,0/0,5,0 --tool 80,31,0/0,-3,0 --merge sum --json --out " + out, dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["merge"], "sum");
  EXPECT_EQ(j["theory"], "euler-bernoulli");
  ASSERT_EQ(j["tools"].size(), 2u);
  for (const char* key : {"point_mm", "action_point_mm", "snap_distance_mm", "beam_length_mm", "displacement_mm",
                          "force_n", "force_magnitude_n"})
    EXPECT_TRUE(j["tools"][1].contains(key)) << key;
  EXPECT_NEAR(j["tools"][1]["snap_distance_mm"].get<double>(), 1.0, 0.1);  // 31 mm → the 30 mm wall
  for (const char* key : {"vertices", "max_displacement_mm", "max_displacement_vertex", "rest_volume_ml",
                          "deformed_volume_ml", "volume_change_percent"})
    EXPECT_TRUE(j["organ"].contains(key)) << key;
  for (const char* key : {"beam_per_tool", "force_per_tool", "deformation"}) EXPECT_TRUE(j["seconds"].contains(key)) << key;
  EXPECT_TRUE(fs::exists(out));
  const CommandRun text = run_organsim("poke " + model + " --tool 150,0,0/0,5,0", dir_);
  ASSERT_EQ(text.exit_code, 0) << text.err;
  EXPECT_NE(text.out.find("force on the tool"), std::string::npos);
  EXPECT_NE(text.out.find("|F| 0.0141 N"), std::string::npos) << text.out;  // 3EIδ/L³ of the helper cylinder
}

TEST_F(Cli, PokeBadInputsFailWithOneLine) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--tool nan,0,0/0,5,0", "NaN"},
      {"--tool 150,0,0/inf,5,0", "NaN or infinite"},
      {"--tool 500,500,500/0,5,0", "farther from the organ surface"},
      {"--tool 0,0,0/0,5,0", "fixed point"},
      {"--tool 150,0,0", "X,Y,Z/DX,DY,DZ"},
      {"--tool 150,0/0,5,0", "X,Y,Z/DX,DY,DZ"},
      {"--tool 150,a,0/0,5,0", "not a number"},
      {"--tool 150,0,0/0,5,0 --out deformed.stl", ".vtp"},
  };
  for (const auto& [arguments, message] : cases) {
    const CommandRun run = run_organsim("poke " + model + " " + arguments, dir_);
    EXPECT_EQ(run.exit_code, 1) << arguments;
    EXPECT_NE(run.err.find(message), std::string::npos) << arguments << ": " << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
  }
  const CommandRun missing = run_organsim("poke " + (dir_ / "absent.organ").string() + " --tool 1,2,3/0,0,1", dir_);
  EXPECT_EQ(missing.exit_code, 1);
  // Two tools at the same point are merged, not an error.
  const CommandRun same = run_organsim("poke " + model + " --tool 150,0,0/0,5,0 --tool 150,0,0/0,5,0 --json", dir_);
  ASSERT_EQ(same.exit_code, 0) << same.err;
  // Within the single-precision distortion's 10 nm (docs/multibeam.md).
  EXPECT_NEAR(nlohmann::json::parse(same.out)["organ"]["max_displacement_mm"].get<double>(), 5.0, 1e-5);
}

std::vector<double> numbers(const nlohmann::json& array) {
  std::vector<double> v;
  for (const auto& x : array) v.push_back(x.get<double>());
  return v;
}

TEST_F(Cli, ReplayForcesEqualPokeForcesOnTheBakedPhantom) {
  // CT → bake → a two-tool session through the real engine (deterministic
  // stepping) → the held forces equal `organsim poke` for the same presses.
  const std::string model = (dir_ / "phantom.organ").string();
  const CommandRun bake = run_organsim("bake " + std::string(ORGANSIM_DATA_SAMPLES) +
                                           "/phantom_ct.nii.gz --seed -65,5,0 --fixed-point -29.76,16.10,-70.96 -o " + model,
                                       dir_);
  ASSERT_EQ(bake.exit_code, 0) << bake.err;
  std::array<std::vector<double>, 2> point, normal;
  for (int k = 0; k < 2; ++k) {
    const CommandRun info = run_organsim("info " + model + " --json --beam " + (k == 0 ? "2000" : "2400"), dir_);
    ASSERT_EQ(info.exit_code, 0) << info.err;
    std::vector<double> p = numbers(nlohmann::json::parse(info.out)["beam"]["position_m"]);
    const std::string at = fmt::format("{},{},{}/0,0,0", p[0] * 1e3, p[1] * 1e3, p[2] * 1e3);
    const CommandRun probe = run_organsim("poke " + model + " --tool " + at + " --json", dir_);
    ASSERT_EQ(probe.exit_code, 0) << probe.err;
    const nlohmann::json t = nlohmann::json::parse(probe.out)["tools"][0];
    point[k] = numbers(t["action_point_mm"]);
    normal[k] = numbers(t["normal"]);
  }
  // Vertices 2000 and 2400 have beams of about 14 cm (forces well below the
  // onset limit). Both tools start 10 mm outside and press 5 mm in along the inward normal,
  // crossing the surface at the same instant, then hold.
  const fs::path session = dir_ / "two_tools.session";
  {
    std::ofstream out(session);
    out << "# organsim session 1\n";
    for (int k = 0; k < 2; ++k)
      for (const auto& [time, depth] : {std::pair{0.0, 10.0}, {1.0, -5.0}, {1.5, -5.0}})
        out << fmt::format("{},{},{:.9f},{:.9f},{:.9f}\n", time, k + 1, point[k][0] + depth * normal[k][0],
                           point[k][1] + depth * normal[k][1], point[k][2] + depth * normal[k][2]);
  }
  const fs::path forces = dir_ / "forces.csv";
  const CommandRun replay = run_organsim("replay " + model + " " + session.string() + " --fast --json --forces " +
                                             forces.string() + " --max-force 100 --max-stiffness 1e6",
                                         dir_);
  ASSERT_EQ(replay.exit_code, 0) << replay.err;
  const nlohmann::json summary = nlohmann::json::parse(replay.out);
  EXPECT_EQ(summary["tools"][0]["contacts"], 1);
  EXPECT_EQ(summary["tools"][1]["contacts"], 1);

  std::string press;
  for (int k = 0; k < 2; ++k)
    press += fmt::format(" --tool {:.9f},{:.9f},{:.9f}/{:.9f},{:.9f},{:.9f}", point[k][0], point[k][1], point[k][2],
                         -5.0 * normal[k][0], -5.0 * normal[k][1], -5.0 * normal[k][2]);
  const CommandRun poke = run_organsim("poke " + model + press + " --json", dir_);
  ASSERT_EQ(poke.exit_code, 0) << poke.err;
  const nlohmann::json expected = nlohmann::json::parse(poke.out)["tools"];

  std::ifstream csv(forces);
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "t_s,tool,fx_n,fy_n,fz_n,in_contact");
  int checked = 0;
  while (std::getline(csv, line)) {
    double t, tool, f[3], contact;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf,%lf,%lf", &t, &tool, &f[0], &f[1], &f[2], &contact), 6);
    if (std::abs(t - 1.4) > 1e-9) continue;
    const std::vector<double> want = numbers(expected[static_cast<int>(tool) - 1]["force_n"]);
    const double scale = std::hypot(want[0], want[1], want[2]);
    ASSERT_GT(scale, 1e-3);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(f[c], want[c], 1e-6 * scale) << "tool " << tool;
    EXPECT_EQ(contact, 1.0);
    ++checked;
  }
  EXPECT_EQ(checked, 2);
}

TEST_F(Cli, ReplayFastIsBitIdenticalAndReportsTheDocumentedKeys) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const fs::path session = dir_ / "press.session";
  {
    std::ofstream out(session);
    out << "# organsim session 1\n0,1,160,0,0\n0.3,1,145,2,0\n0.6,1,160,0,0\n0,2,80,40,0\n0.3,2,80,26,1\n0.6,2,80,40,0\n";
  }
  std::array<std::string, 2> csv;
  for (int run = 0; run < 2; ++run) {
    const fs::path forces = dir_ / fmt::format("forces_{}.csv", run);
    const fs::path frames = dir_ / fmt::format("frames_{}", run);
    const CommandRun replay = run_organsim("replay " + model + " " + session.string() + " --fast --json --forces " +
                                               forces.string() + " --frames " + frames.string(),
                                           dir_);
    ASSERT_EQ(replay.exit_code, 0) << replay.err;
    const nlohmann::json j = nlohmann::json::parse(replay.out);
    for (const char* key : {"model", "session", "mode", "merge", "duration_s", "wall_s", "tools", "force_loop",
                            "deformation_loop", "refused_contacts", "forces_csv", "frames"})
      EXPECT_TRUE(j.contains(key)) << key;
    for (const char* key : {"tool", "contacts", "peak_force_n", "clamped_ticks", "watchdog_ticks", "non_finite_forces"})
      EXPECT_TRUE(j["tools"][1].contains(key)) << key;
    for (const char* key : {"ticks", "period", "compute", "deadline_misses", "realtime_priority"})
      EXPECT_TRUE(j["force_loop"].contains(key)) << key;
    EXPECT_EQ(j["force_loop"]["ticks"], 601);
    EXPECT_EQ(j["deformation_loop"]["frames"], 37);
    EXPECT_EQ(j["frames"]["count"], 37);
    EXPECT_TRUE(fs::exists(frames / "frames.pvd"));
    EXPECT_TRUE(fs::exists(frames / "frame_00037.vtp"));
    std::ifstream in(forces);
    csv[run].assign(std::istreambuf_iterator<char>(in), {});
    EXPECT_EQ(j["tools"][0]["contacts"], 1);
    EXPECT_GT(j["tools"][0]["peak_force_n"].get<double>(), 0.01);
  }
  EXPECT_EQ(csv[0], csv[1]);
  EXPECT_GT(csv[0].size(), 1000u);
}

TEST_F(Cli, ReplayBadInputsFailWithOneLine) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const fs::path bad = dir_ / "bad.session";
  {
    std::ofstream out(bad);
    out << "# organsim session 1\n0,1,160,0\n";
  }
  const std::vector<std::pair<std::string, std::string>> cases = {
      {(dir_ / "absent.session").string(), "cannot open the session file"},
      {bad.string(), "bad.session:2: expected 5 or 8 comma-separated fields"},
  };
  for (const auto& [arguments, message] : cases) {
    const CommandRun run = run_organsim("replay " + model + " " + arguments + " --fast", dir_);
    EXPECT_EQ(run.exit_code, 1) << arguments;
    EXPECT_NE(run.err.find(message), std::string::npos) << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
  }
}

TEST_F(Cli, TouchRunsOpenHapticsDevicesFromALibraryLoadedAtRunTime) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const CommandRun run =
      run_organsim("touch " + model + " --hd-library " + std::string(FAKE_HD_LIBRARY) + " --seconds 0.5 --json", dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_NEAR(j["servo_rate_hz"].get<double>(), 1000.0, 300.0);  // wide: CI runs two test programs at once
  EXPECT_GE(j["deformation_frames"].get<int>(), 25);
  EXPECT_DOUBLE_EQ(j["tools"][0]["max_force_n"].get<double>(), 2.5);  // the stand-in device's limit
  const CommandRun missing = run_organsim("touch " + model + " --hd-library /nonexistent/libHD.so --seconds 0.1", dir_);
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("cannot load the OpenHaptics HD library"), std::string::npos) << missing.err;
  EXPECT_EQ(std::count(missing.err.begin(), missing.err.end(), '\n'), 1) << missing.err;
}

// Runs organsim under a virtual X server (the viewer renders with OpenGL).
CommandRun run_viewer(const std::string& arguments, const fs::path& dir) {
  return run_organsim_with_prefix("xvfb-run -a -s '-screen 0 1280x1024x24' ", arguments, dir);
}

// A cylinder (helper model, axis x, radius 30 mm, clamped at x = 0) pressed by
// two tools 10 mm down into its top (+z, the top of the viewer's default
// picture) at x = 60 and 130 mm, and held.
fs::path write_press_session(const fs::path& dir) {
  const fs::path session = dir / "press.session";
  std::ofstream out(session);
  out << "# organsim session 1\n0,1,60,0,50\n0.4,1,60,0,20\n1.0,1,60,0,20\n"
         "0,2,130,0,50\n0.4,2,130,0,20\n1.0,2,130,0,20\n";
  return session;
}

TEST_F(Cli, ViewScreenshotShowsTheOrganMovedWhereTheToolsPushed) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const std::string session = write_press_session(dir_).string();
  const fs::path rest = dir_ / "rest.png", pushed = dir_ / "pushed.png";
  const CommandRun first = run_viewer("view " + model + " --session " + session +
                                          " --offscreen --hide-tools --frames 1 --screenshot " + rest.string(),
                                      dir_);
  ASSERT_EQ(first.exit_code, 0) << first.err;
  const CommandRun last = run_viewer(
      "view " + model + " --session " + session + " --offscreen --hide-tools --json --screenshot " + pushed.string(), dir_);
  ASSERT_EQ(last.exit_code, 0) << last.err;
  const nlohmann::json j = nlohmann::json::parse(last.out);
  EXPECT_EQ(j["frames"], 61);
  std::array<Eigen::Vector2d, 2> tip;
  for (int k = 0; k < 2; ++k) {
    EXPECT_EQ(j["tools"][k]["contacts"], 1);
    tip[k] = {j["tools"][k]["tip_px"][0].get<double>(), j["tools"][k]["tip_px"][1].get<double>()};
  }
  // A control spot on the organ near the clamped end (x ≈ 5 mm), where
  // neither tool's press reaches much: pixels per metre from the two tips.
  const double pixels_per_metre = (tip[1][0] - tip[0][0]) / 0.07;
  const Eigen::Vector2d clamp(tip[0][0] - 0.055 * pixels_per_metre, tip[0][1]);

  const cv::Mat a = cv::imread(rest.string()), b = cv::imread(pushed.string());
  ASSERT_FALSE(a.empty());
  ASSERT_EQ(a.size(), b.size());
  cv::Mat difference;
  cv::absdiff(a, b, difference);
  cv::cvtColor(difference, difference, cv::COLOR_BGR2GRAY);
  long changed = 0, near_clamp = 0;
  std::array<long, 2> near_tool{};
  for (int r = 0; r < difference.rows; ++r)
    for (int c = 0; c < difference.cols; ++c)
      if (difference.at<unsigned char>(r, c) > 20) {
        ++changed;
        const Eigen::Vector2d pixel(c, r);
        for (int k = 0; k < 2; ++k) near_tool[k] += (pixel - tip[k]).norm() < 80.0;
        near_clamp += (pixel - clamp).norm() < 80.0;
      }
  ASSERT_GT(changed, 300) << "the organ did not move on screen";
  for (int k = 0; k < 2; ++k) {
    EXPECT_GT(near_tool[k], 1000) << "around tool " << k + 1 << " the picture changed little";
    EXPECT_GT(near_tool[k], 3 * near_clamp) << near_tool[k] << " changed pixels near tool " << k + 1 << ", "
                                             << near_clamp << " near the clamp";
  }
}

TEST_F(Cli, ViewRecordsEveryFrameAndStartsWithoutABrokenBackground) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  const std::string session = write_press_session(dir_).string();
  const fs::path video = dir_ / "session.avi", shot = dir_ / "shot.png";
  const CommandRun run = run_viewer("view " + model + " --session " + session + " --offscreen --frames 30 --record " +
                                        video.string() + " --background " + (dir_ / "missing.png").string() +
                                        " --screenshot " + shot.string(),
                                    dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("warning"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("missing.png does not exist"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("starting without a background"), std::string::npos) << run.err;
  EXPECT_TRUE(fs::exists(shot));
  // An unreadable background (not an image, not a video) is the same: a warning.
  const fs::path garbage = dir_ / "garbage.png";
  std::ofstream(garbage) << "not an image";
  const CommandRun unreadable = run_viewer("view " + model + " --session " + session + " --offscreen --frames 2 " +
                                               "--background " + garbage.string(),
                                           dir_);
  ASSERT_EQ(unreadable.exit_code, 0) << unreadable.err;
  EXPECT_NE(unreadable.err.find("neither an image nor a video"), std::string::npos) << unreadable.err;
  cv::VideoCapture capture(video.string());
  ASSERT_TRUE(capture.isOpened());
  int frames = 0;
  cv::Mat frame;
  while (capture.read(frame)) ++frames;
  EXPECT_EQ(frames, 30);
  EXPECT_EQ(frame.empty() ? 0 : frame.cols, 0);  // read past the end
  // A background that is an image is drawn behind the organ.
  const fs::path backdrop = dir_ / "backdrop.png";
  cv::imwrite(backdrop.string(), cv::Mat(120, 160, CV_8UC3, cv::Scalar(0, 200, 0)));
  const fs::path green = dir_ / "green.png";
  const CommandRun with = run_viewer("view " + model + " --session " + session + " --offscreen --frames 1 --background " +
                                         backdrop.string() + " --screenshot " + green.string(),
                                     dir_);
  ASSERT_EQ(with.exit_code, 0) << with.err;
  const cv::Mat picture = cv::imread(green.string());
  const cv::Vec3b corner = picture.at<cv::Vec3b>(5, 5);
  EXPECT_GT(corner[1], 150);  // green backdrop in the corner
  EXPECT_LT(corner[2], 60);
}

TEST_F(Cli, ViewRunsMouseToolsAndPhantomDevicesInRealTime) {
  const std::string model = (dir_ / "cylinder.organ").string();
  model::write_organ_model_file(testing::make_cylinder_model({}), model);
  // Mouse tools: a window (under Xvfb) with the loops on their threads.
  const CommandRun mouse = run_viewer("view " + model + " --frames 20 --json", dir_);
  ASSERT_EQ(mouse.exit_code, 0) << mouse.err;
  EXPECT_EQ(nlohmann::json::parse(mouse.out)["frames"], 20);
  // PHANToM devices from the HD library (here the stand-in): the servo drives the force loop.
  const CommandRun phantom = run_viewer(
      "view " + model + " --phantom --hd-library " + std::string(FAKE_HD_LIBRARY) + " --frames 20 --json", dir_);
  ASSERT_EQ(phantom.exit_code, 0) << phantom.err;
  EXPECT_EQ(nlohmann::json::parse(phantom.out)["frames"], 20);
  const CommandRun missing = run_viewer("view " + model + " --phantom --hd-library /nonexistent/libHD.so --frames 2", dir_);
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("cannot load the OpenHaptics HD library"), std::string::npos) << missing.err;
}

}  // namespace
}  // namespace organsim

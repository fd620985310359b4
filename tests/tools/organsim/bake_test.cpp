// `organsim bake`: the JSON report, byte-identical models, no patient tag in
// any output, and bad inputs that leave no model behind.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "cli_fixture.h"
#include "oversized_ct.h"
#include "organsim/model/model_file.h"
#include "organsim/pipeline/image_io.h"
#include "organsim/pipeline/phantom.h"

namespace organsim {
namespace {

using namespace cli::testing;

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

// Supports (docs/supports.md): the phantom CT's liver lies against its
// neighbours in places; the bake stores them, info and export show them, and
// --supports none leaves only them out.
TEST_F(Cli, BakeFindsTheSupportsInTheCtAndInfoAndExportShowThem) {
  const fs::path model = dir_ / "liver.organ", bare = dir_ / "bare.organ", surface = dir_ / "surface.vtp";
  const CommandRun run = run_organsim("bake " + quick_phantom_bake(model) + " --json", dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json s = nlohmann::json::parse(run.out)["supports"];
  EXPECT_TRUE(s["found"].get<bool>());
  EXPECT_GT(s["contact_area_cm2"].get<double>() + s["attachment_area_cm2"].get<double>(), 0.0);
  EXPECT_LT(s["contact_area_cm2"].get<double>() + s["attachment_area_cm2"].get<double>(),
            s["surface_area_cm2"].get<double>());
  EXPECT_DOUBLE_EQ(s["foundation_modulus_pa_per_m"].get<double>(), 5000.0 / 0.020);
  const model::ModelReadResult with = model::read_organ_model_file(model.string());
  ASSERT_TRUE(with) << with.error;
  EXPECT_EQ(with.model->supports.vertices.size(), with.model->surface_vertices.size());
  const CommandRun info = run_organsim("info " + model.string() + " --json", dir_);
  ASSERT_EQ(info.exit_code, 0) << info.err;
  const nlohmann::json i = nlohmann::json::parse(info.out)["supports"];
  EXPECT_EQ(i["contact_vertices"].get<std::size_t>() + i["attachment_vertices"].get<std::size_t>(),
            s["contact_vertices"].get<std::size_t>() + s["attachment_vertices"].get<std::size_t>());
  EXPECT_NE(run_organsim("info " + model.string(), dir_).out.find("supports        contact"), std::string::npos);
  const CommandRun exported = run_organsim("export " + model.string() + " --surface " + surface.string(), dir_);
  ASSERT_EQ(exported.exit_code, 0) << exported.err;
  EXPECT_NE(read_bytes(surface).find("Name=\"support_kind\""), std::string::npos);

  const CommandRun none = run_organsim("bake " + quick_phantom_bake(bare) + " --supports none --json", dir_);
  ASSERT_EQ(none.exit_code, 0) << none.err;
  EXPECT_FALSE(nlohmann::json::parse(none.out)["supports"]["found"].get<bool>());
  const model::ModelReadResult without = model::read_organ_model_file(bare.string());
  ASSERT_TRUE(without) << without.error;
  EXPECT_TRUE(without.model->supports.empty());
  EXPECT_EQ(without.model->surface_vertices, with.model->surface_vertices);
  EXPECT_EQ(without.model->tetrahedra, with.model->tetrahedra);
  EXPECT_EQ(run_organsim("bake " + quick_phantom_bake(dir_ / "x.organ") + " --supports body", dir_).exit_code, 2);
}

TEST_F(Cli, BakeIsByteIdenticalAcrossRuns) {
  ASSERT_EQ(run_organsim("bake " + quick_phantom_bake(dir_ / "a.organ"), dir_).exit_code, 0);
  ASSERT_EQ(run_organsim("bake " + quick_phantom_bake(dir_ / "b.organ") + " --threads 1", dir_).exit_code, 0);
  EXPECT_TRUE(read_bytes(dir_ / "a.organ") == read_bytes(dir_ / "b.organ"));
}

// The site compliances (docs/matching.md): the phantom at the default
// tetrahedron size, clamped at its portal-vein entry, gets them, the same
// bytes with one thread or all; --no-site-compliance leaves only them out;
// the quick bake's 12 mm tetrahedra, which the FEM clamp cannot hold, get
// none and the report says why.
TEST_F(Cli, BakeStoresSiteCompliancesTheSameWhateverTheThreads) {
  const std::string phantom = (fs::path(ORGANSIM_DATA_SAMPLES) / "phantom_ct.nii.gz").string() +
                              " --seed -65,5,0 --fixed-point -29.76,16.10,-70.96 --no-beam-tables";
  const fs::path all = dir_ / "all.organ", one = dir_ / "one.organ", none = dir_ / "none.organ";
  const CommandRun run = run_organsim("bake " + phantom + " -o " + all.string() + " --json", dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  ASSERT_TRUE(j["site_compliance"]["computed"].get<bool>()) << run.out;
  EXPECT_GT(j["site_compliance"]["boundary_nodes"].get<int>(), 100);
  EXPECT_GT(j["seconds"]["stages"]["site compliance"].get<double>(), 0.0);
  ASSERT_EQ(run_organsim("bake " + phantom + " -o " + one.string() + " --threads 1", dir_).exit_code, 0);
  EXPECT_TRUE(read_bytes(all) == read_bytes(one));
  ASSERT_EQ(run_organsim("bake " + phantom + " -o " + none.string() + " --no-site-compliance", dir_).exit_code, 0);
  const model::OrganModel with = *model::read_organ_model_file(all.string()).model;
  model::OrganModel without = *model::read_organ_model_file(none.string()).model;
  ASSERT_EQ(with.sites.compliance.size(), with.surface_vertices.size());
  EXPECT_TRUE(without.sites.empty());
  without.sites = with.sites;
  without.provenance.parameters["site_compliance"] = with.provenance.parameters.at("site_compliance");
  EXPECT_TRUE(without == with);
  const CommandRun info = run_organsim("info " + all.string(), dir_);
  EXPECT_NE(info.out.find("site compliance the FEM reference's normal stiffness"), std::string::npos) << info.out;

  const CommandRun quick = run_organsim("bake " + quick_phantom_bake(dir_ / "quick.organ") + " --json", dir_);
  ASSERT_EQ(quick.exit_code, 0) << quick.err;
  const nlohmann::json q = nlohmann::json::parse(quick.out);
  EXPECT_FALSE(q["site_compliance"]["computed"].get<bool>());
  EXPECT_NE(q["site_compliance"]["reason"].get<std::string>().find("clamp radius"), std::string::npos) << quick.out;
}

TEST_F(Cli, BakeWithoutBeamTablesSkipsTheStageAndKeepsEverythingElse) {
  // --no-beam-tables: no beam-table stage and no tables in the file; the rest
  // of the model (surface, tetrahedra, material) is the full bake's, array for
  // array. --stations 0 stays refused, and its message names the option.
  const fs::path full = dir_ / "full.organ", bare = dir_ / "bare.organ";
  ASSERT_EQ(run_organsim("bake " + quick_phantom_bake(full), dir_).exit_code, 0);
  const CommandRun run = run_organsim("bake " + quick_phantom_bake(bare) + " --no-beam-tables --json", dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["beams"]["stations"], 0);
  EXPECT_FALSE(j["seconds"]["stages"].contains("beam tables"));
  const model::ModelReadResult with = model::read_organ_model_file(full.string());
  const model::ModelReadResult without = model::read_organ_model_file(bare.string());
  ASSERT_TRUE(with && without) << with.error << without.error;
  EXPECT_TRUE(without.model->beams.empty());
  EXPECT_FALSE(with.model->beams.empty());
  EXPECT_EQ(without.model->surface_vertices, with.model->surface_vertices);
  EXPECT_EQ(without.model->surface_triangles, with.model->surface_triangles);
  EXPECT_EQ(without.model->volume_vertices, with.model->volume_vertices);
  EXPECT_EQ(without.model->tetrahedra, with.model->tetrahedra);
  EXPECT_EQ(without.model->fixed_points, with.model->fixed_points);
  EXPECT_LT(fs::file_size(bare), fs::file_size(full) / 2);

  std::string zero_stations = quick_phantom_bake(dir_ / "zero.organ");
  zero_stations.replace(zero_stations.find("--stations 8"), 12, "--stations 0");
  const CommandRun zero = run_organsim("bake " + zero_stations, dir_);
  EXPECT_EQ(zero.exit_code, 1);
  EXPECT_NE(zero.err.find("--no-beam-tables"), std::string::npos) << zero.err;
  EXPECT_FALSE(fs::exists(dir_ / "zero.organ"));
}

TEST_F(Cli, BakeRefinesTheTetrahedraWhereAsked) {
  // --refine-at: more, finer tetrahedra around a surface point, the surface
  // and the volume unchanged, the places in the provenance.
  const fs::path plain = dir_ / "plain.organ", refined = dir_ / "refined.organ";
  ASSERT_EQ(run_organsim("bake " + quick_phantom_bake(plain) + " --no-beam-tables", dir_).exit_code, 0);
  const model::ModelReadResult before = model::read_organ_model_file(plain.string());
  ASSERT_TRUE(before) << before.error;
  const model::Point3 at = before.model->surface_vertices.front();
  const std::string place =
      std::to_string(at[0] * 1e3) + "," + std::to_string(at[1] * 1e3) + "," + std::to_string(at[2] * 1e3);
  const CommandRun run = run_organsim(
      "bake " + quick_phantom_bake(refined) + " --no-beam-tables --refine-at " + place + " --refine-size 3 --json",
      dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const model::ModelReadResult after = model::read_organ_model_file(refined.string());
  ASSERT_TRUE(after) << after.error;
  EXPECT_GT(after.model->tetrahedra.size(), before.model->tetrahedra.size() + 100);
  EXPECT_EQ(after.model->surface_vertices, before.model->surface_vertices);
  EXPECT_NE(after.model->provenance.parameters.at("tetrahedra_refined").find("at 3 mm"), std::string::npos);
  EXPECT_EQ(before.model->provenance.parameters.count("tetrahedra_refined"), 0u);
  const nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_NEAR(j["tetrahedra"]["volume_ml"].get<double>(), j["surface"]["volume_ml"].get<double>(),
              1e-4 * j["surface"]["volume_ml"].get<double>());
}

TEST_F(Cli, NoPatientTagReachesTheModelTheReportOrTheLog) {
  // A DICOM series with a known patient name, ID and birth date.
  const pipeline::Phantom phantom = pipeline::make_phantom(pipeline::PhantomOptions{});
  pipeline::DicomSeriesInfo info;
  info.patient_name = "DOE^JANE^QUINCY";
  info.patient_id = "MRN-4711-0815";
  info.series_description = "CT ABDOMEN DOE-JANE-QUINCY";
  info.uid_seed = 4711;
  pipeline::write_dicom_series(*phantom.ct, (dir_ / "dicom").string(), info);
  const std::string slice = read_bytes(fs::directory_iterator(dir_ / "dicom")->path());
  ASSERT_NE(slice.find("DOE^JANE"), std::string::npos);
  // Every name and number that could tie the model to the study: the
  // patient's, the series description, and the study, series, frame-of-
  // reference and instance UIDs (DICOM UIDs under the 2.25 root).
  std::vector<std::string> identifying = {"DOE^", "QUINCY", "MRN-4711", "DOE-JANE"};
  for (std::size_t at = slice.find("2.25."); at != std::string::npos; at = slice.find("2.25.", at + 1)) {
    const std::size_t end = slice.find_first_not_of("0123456789.", at);
    identifying.push_back(slice.substr(at, end - at));
  }
  ASSERT_GE(identifying.size(), 4u + 4u) << "the study, series, frame and instance UIDs";
  const auto expect_none = [&](const std::string& text, const std::string& where) {
    for (const std::string& needle : identifying)
      EXPECT_EQ(text.find(needle), std::string::npos) << needle << " in " << where;
  };

  const fs::path model = dir_ / "liver.organ";
  const std::string bake =
      "bake " + (dir_ / "dicom").string() +
      " --seed -65,5,0 --surface-vertices 800 --tet-size 12 --stations 8 --section-samples 32 -o " + model.string() +
      " --intermediates " + (dir_ / "inspect").string();
  for (const std::string& extra : {std::string(), std::string(" --json")}) {
    const CommandRun run = run_organsim(bake + extra, dir_);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    expect_none(run.out, "bake's output");
    expect_none(run.err, "bake's messages");
    expect_none(read_bytes(model), "the model file");
  }
  // Nor any file of a training report of a session on that model.
  const fs::path session = dir_ / "tools.session";
  std::ofstream(session) << "# organsim session 1\n0,1,-65,5,200\n0.2,1,-65,5,190\n";
  const CommandRun replay = run_organsim(
      "replay " + model.string() + " " + session.string() + " --fast --report " + (dir_ / "report").string(), dir_);
  ASSERT_EQ(replay.exit_code, 0) << replay.err;
  for (const auto& entry : fs::directory_iterator(dir_ / "report")) expect_none(read_bytes(entry.path()), entry.path());
  // Longer needles in the intermediates: their base64 data holds any short
  // word by chance ("DOE" about once in 250 kB); '^' and '-' are not base64.
  // (the UIDs hold '.', which is not base64 either).
  for (const auto& entry : fs::directory_iterator(dir_ / "inspect"))
    expect_none(read_bytes(entry.path()), entry.path());
}

// The disk fills while the model is written (a file-size limit stands in):
// one line naming the model file and the reason, and nothing left behind.
TEST_F(Cli, BakeOnAFullDiskFailsWithOneLineAndLeavesNothing) {
  const fs::path model = dir_ / "model.organ";
  const CommandRun run = run_organsim_with_prefix("ulimit -f 100; ", "bake --quiet " + quick_phantom_bake(model), dir_);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("cannot write '" + model.string() + "'"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("File too large"), std::string::npos) << run.err;
  EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
  EXPECT_FALSE(fs::exists(model));
  EXPECT_EQ(files_in_dir(), 0u);
}

// Killed (SIGKILL: no handler runs) at several stages of a bake: nothing ever
// appears at the output path, since the model is written to a temporary file
// and renamed into place only once complete.
TEST_F(Cli, BakeKilledAtAnyStageLeavesNothingAtTheOutputPath) {
  const fs::path model = dir_ / "model.organ", log = dir_ / "bake.log";
  const std::string bake = std::string(ORGANSIM_EXECUTABLE) + " bake " + (kSamples / "phantom_ct.nii.gz").string() +
                           " --seed -65,5,0 --fixed-point -29.76,16.10,-70.96 --verbose -o " + model.string() + " 2>" +
                           log.string();
  std::vector<std::string> interrupted;
  for (const double delay : {0.3, 0.9, 1.6, 2.4, 3.0}) {
    const std::string command =
        "sh -c '" + bake + " & sleep " + std::to_string(delay) + "; kill -KILL $! 2>/dev/null; wait $!'";
    const int status = std::system(command.c_str());
    (void)status;
    std::ifstream in(log);
    std::string line, stage;
    for (std::string text; std::getline(in, text);)
      if (text.size() > 4 && text.compare(text.size() - 4, 4, " ...") == 0) stage = text;
    const bool finished = fs::exists(model);
    if (finished) {  // a fast machine finished first: then the model is whole
      const model::ModelReadResult read = model::read_organ_model_file(model.string());
      EXPECT_TRUE(read) << read.error;
      fs::remove(model);
      continue;
    }
    interrupted.push_back(stage);
    EXPECT_FALSE(fs::exists(model)) << delay << " s, " << stage;
  }
  std::sort(interrupted.begin(), interrupted.end());
  interrupted.erase(std::unique(interrupted.begin(), interrupted.end()), interrupted.end());
  EXPECT_GE(interrupted.size(), 2u);  // killed in different stages (segment, tetrahedra, beam tables on this machine)
  for (const std::string& stage : interrupted) ::testing::Test::RecordProperty("killed_in", stage);
}

TEST_F(Cli, BakeBadInputsFailWithOneLineAndLeaveNoModel) {
  const fs::path model = dir_ / "out" / "liver.organ";
  fs::create_directories(model.parent_path());
  const std::string ct = (kSamples / "phantom_ct.nii.gz").string();
  const std::string quick =
      " --surface-vertices 800 --tet-size 12 --stations 8 --section-samples 32 -o " + model.string();
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
  pipeline::write_ct_image(*phantom.ct, (dir_ / "small.nii").string());
  testing::write_oversized_nifti((dir_ / "small.nii").string(), (dir_ / "huge.nii.gz").string(), 30000);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {dir_.string() + "/missing.nii.gz --seed 0,0,0", "missing.nii.gz"},
      {(dir_ / "notes.nii.gz").string() + " --seed 0,0,0", "notes.nii.gz"},
      {(dir_ / "huge.nii.gz").string() + " --seed 0,0,0", "is 30000x30000x30000 voxels; baking it needs about"},
      {(dir_ / "two_series").string() + " --seed -65,5,0", "second series"},
      {ct + " --seed 900,0,0", "outside the volume"},
      {ct + " --seed-voxel 500,3,3", "outside the volume"},
      {ct + " --seed 0,-100,0", "lies in fat"},
      {ct, "no segmentation"},
      {ct + " --label " + (kSamples / "phantom_liver_mask.nii.gz").string() + " --label-value 3", "label value 3"},
      {ct + " --label " + (kSamples / "real_ct_totalseg" / "liver_mask_ct.nii.gz").string(), "does not match"},
      {ct + " --seed -65,5,0 --fixed-point 150,150,90", "outside the organ"},
      {ct + " --seed -65,5,0 --poisson-ratio 0.5", "--poisson-ratio"},
      {ct + " --seed -65,5,0 --facet-distance 0", "--facet-distance"},
      {ct + " --seed -65,5,0 --refine-at 1,2", "--refine-at 1,2"},
      {ct + " --seed -65,5,0 --refine-at nan,0,0", "finite centre"},
  };
  for (const auto& [arguments, fragment] : cases) {
    const CommandRun run = run_organsim("bake " + arguments + quick, dir_);
    EXPECT_EQ(run.exit_code, 1) << arguments;
    const std::string last_line = run.err.substr(
        run.err.rfind("organsim bake: error: ") == std::string::npos ? 0 : run.err.rfind("organsim bake: error: "));
    EXPECT_NE(last_line.find(fragment), std::string::npos) << arguments << "\n" << run.err;
    EXPECT_EQ(std::count(last_line.begin(), last_line.end(), '\n'), 1) << run.err;
    EXPECT_FALSE(fs::exists(model)) << arguments;
    EXPECT_TRUE(fs::is_empty(model.parent_path())) << arguments;  // no temporary file either
  }
}

}  // namespace
}  // namespace organsim

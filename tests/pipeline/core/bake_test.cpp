// The whole pipeline (bake()) on the phantom, the real CT samples and
// synthetic volumes: what it makes, that it is deterministic, and its errors.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <fstream>
#include <string>
#include <vector>

#include "organsim/model/model_file.h"
#include "organsim/pipeline/bake.h"
#include "organsim/pipeline/ct_input.h"
#include "organsim/pipeline/image_hash.h"
#include "organsim/pipeline/image_io.h"
#include "organsim/pipeline/phantom.h"
#include "organsim/pipeline/segmentation.h"
#include "synthetic_volumes.h"
#include "temp_directory.h"

namespace organsim::pipeline {
namespace {

namespace fs = std::filesystem;

const fs::path kSamples = ORGANSIM_DATA_SAMPLES;

class Bake : public organsim::testing::TempDirectoryTest {
 protected:
  /// Options for the shipped phantom, segmented from a seed in the right lobe.
  static BakeOptions phantom_options() {
    BakeOptions o;
    o.ct_path = (kSamples / "phantom_ct.nii.gz").string();
    o.seeded.seeds = {SeedPoint::at_mm({-65.0, 5.0, 0.0})};
    o.surface.target_vertices = 1500;
    o.tetrahedra.tet_size_mm = 10.0;
    o.beams.stations = 10;
    o.beams.samples_per_side = 48;
    o.program_version = "test";
    return o;
  }
};

double relative_difference(double value, double reference) { return std::abs(value / reference - 1.0); }

/// The tetrahedral nodes the FEM models' clamp holds: those within 10 mm of
/// the fixed point. The bake meshes that ball with 2.5 mm cells
/// (BakeOptions::clamp_cells_mm), so which nodes it holds no longer hangs on
/// the meshing.
std::size_t clamped_nodes(const model::OrganModel& m) {
  const model::Point3& fixed = m.fixed_points.at(0);
  std::size_t clamped = 0;
  for (const model::Point3& v : m.volume_vertices)
    clamped += std::hypot(v[0] - fixed[0], v[1] - fixed[1], v[2] - fixed[2]) <= 0.010;
  return clamped;
}

/// Cones on the surface: vertices whose angle deficit (360° less the angles of
/// their triangles) exceeds 45°, and the largest deficit. A smooth organ's
/// 3,000 vertices share 720° of total curvature, a fraction of a degree each;
/// at a cone's tip a tool meets one node of the FEM mesh.
struct Spikes {
  std::size_t over_45_deg = 0;
  double largest_deg = -360.0;
};

/// `only`: the vertices counted (all when empty).
Spikes surface_spikes(const model::OrganModel& m, const std::function<bool(const model::Point3&)>& only = {}) {
  std::vector<double> angles(m.surface_vertices.size(), 0.0);
  for (const model::Triangle& t : m.surface_triangles)
    for (int k = 0; k < 3; ++k) {
      const model::Point3 &p = m.surface_vertices[t[k]], &q = m.surface_vertices[t[(k + 1) % 3]],
                          &r = m.surface_vertices[t[(k + 2) % 3]];
      const double u[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]}, w[3] = {r[0] - p[0], r[1] - p[1], r[2] - p[2]};
      const double cross = std::hypot(u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]);
      angles[t[k]] += std::atan2(cross, u[0] * w[0] + u[1] * w[1] + u[2] * w[2]);
    }
  Spikes spikes;
  for (std::size_t v = 0; v < angles.size(); ++v) {
    if (only && !only(m.surface_vertices[v])) continue;
    const double deficit_deg = 360.0 - angles[v] * 180.0 / M_PI;
    spikes.over_45_deg += deficit_deg > 45.0;
    spikes.largest_deg = std::max(spikes.largest_deg, deficit_deg);
  }
  return spikes;
}

TEST_F(Bake, PhantomFromASeedGivesAValidModelWithConsistentVolumes) {
  BakeOptions o = phantom_options();
  o.fixed_point_mm = std::array<double, 3>{-29.76, 16.10, -70.96};  // the portal vein entry
  std::vector<std::string> stages;
  const BakeResult result = bake(o, [&](const std::string& stage, double fraction) {
    if (fraction == 0.0) stages.push_back(stage);
  });
  const model::OrganModel& m = result.model;
  const BakeReport& r = result.report;
  EXPECT_EQ(model::validate_organ_model(m), "");
  EXPECT_EQ(stages, (std::vector<std::string>{"read CT", "segment", "fixed point", "surface", "beam tables",
                                              "tetrahedra", "assemble", "supports", "site compliance"}));
  EXPECT_EQ(m.sites.compliance.size(), m.surface_vertices.size());  // the portal-vein clamp holds the phantom
  EXPECT_EQ(r.stage_seconds.size(), stages.size());

  // Volumes: tetrahedra and surface within 3 % of the mask; the mask near the
  // phantom's ground truth (the seeded segmentation excludes the portal vein).
  EXPECT_LT(relative_difference(r.tetrahedra_volume_ml, r.mask_volume_ml), 0.03);
  EXPECT_LT(relative_difference(r.surface_volume_ml, r.mask_volume_ml), 0.03);
  EXPECT_LT(relative_difference(r.mask_volume_ml, 1573.7), 0.05);
  EXPECT_NEAR(static_cast<double>(m.surface_vertices.size()), 1500.0, 150.0);
  // No inverted or flat tetrahedron, and the quality goals met.
  EXPECT_GE(r.tetrahedra.min_dihedral_deg, kMinDihedralGoalDeg);
  EXPECT_LE(r.tetrahedra.max_radius_edge_ratio, kMaxRadiusEdgeGoal);
  EXPECT_GT(r.tetrahedra.min_volume_m3, 0.0);

  // The fixed point as given, in metres; the beams go from it to every vertex.
  ASSERT_EQ(m.fixed_points.size(), 1u);
  EXPECT_NEAR(m.fixed_points[0][0], -0.02976, 1e-12);
  EXPECT_EQ(r.fixed_point_source, "given point");
  EXPECT_LT(r.fixed_point_outside_mm, 10.0);
  EXPECT_EQ(m.beams.stations_per_beam, 10u);
  EXPECT_EQ(m.beams.sections.size(), 10 * m.surface_vertices.size());

  // Provenance: the image hash, every parameter, never a path.
  EXPECT_EQ(m.provenance.input_sha256, image_sha256(*read_ct(o.ct_path)));
  EXPECT_EQ(m.provenance.input_sha256.size(), 64u);
  EXPECT_EQ(m.provenance.parameters.at("tet_size_mm"), "10");
  // The meshing as model data, for a program that meshes the organ again.
  EXPECT_DOUBLE_EQ(m.meshing.tet_size, 0.010);
  EXPECT_EQ(m.provenance.parameters.at("fixed_point_source"), "given point");
  for (const auto& [key, value] : m.provenance.parameters)
    EXPECT_EQ(value.find("phantom_ct"), std::string::npos) << key;
  EXPECT_EQ(m.material, model::liver_default_material());

  ASSERT_EQ(m.surface_texcoords.size(), m.surface_vertices.size());
  for (const model::TexCoord& t : m.surface_texcoords) {
    EXPECT_TRUE(t[0] >= 0.0 && t[0] <= 1.0 && t[1] >= 0.0 && t[1] <= 1.0);
  }
}

TEST_F(Bake, SameInputAndOptionsGiveTheSameModelBytes) {
  BakeOptions o = phantom_options();
  const std::vector<std::uint8_t> first = model::serialize_organ_model(bake(o).model);
  o.beams.threads = 1;  // the thread count must not matter either
  const std::vector<std::uint8_t> second = model::serialize_organ_model(bake(o).model);
  EXPECT_TRUE(first == second);
}

TEST_F(Bake, IntermediatesAreWrittenForInspection) {
  BakeOptions o = phantom_options();
  o.intermediates_dir = (dir_ / "intermediates").string();
  const BakeResult result = bake(o);
  for (const char* name : {"mask.nii.gz", "surface.vtp", "surface.stl", "tetrahedra.vtu"}) {
    const fs::path path = dir_ / "intermediates" / name;
    ASSERT_TRUE(fs::exists(path)) << name;
    EXPECT_GT(fs::file_size(path), 1000u) << name;
  }
  // The mask is on the CT's grid: it can be fed back as --label.
  const CtImage::Pointer ct = read_ct(o.ct_path);
  const MaskImage::Pointer mask = read_label_mask((dir_ / "intermediates" / "mask.nii.gz").string(), 1, *ct);
  EXPECT_EQ(count_voxels(*mask), result.report.mask_voxels);
  // Binary STL: 84-byte header and count, 50 bytes per triangle.
  EXPECT_EQ(fs::file_size(dir_ / "intermediates" / "surface.stl"), 84 + 50 * result.model.surface_triangles.size());
  for (const auto& entry : fs::directory_iterator(dir_ / "intermediates"))
    EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos);  // no temporary left
}

TEST_F(Bake, AFailedBakeLeavesNoIntermediatesAndNoModel) {
  // The last step fails (the model file's directory is missing), after the
  // mask, surface and tetrahedra were written.
  BakeOptions o = phantom_options();
  o.intermediates_dir = (dir_ / "intermediates").string();
  o.output_path = (dir_ / "missing" / "liver.organ").string();
  EXPECT_THROW(bake(o), std::runtime_error);
  EXPECT_FALSE(fs::exists(dir_ / "intermediates"));  // made by the bake, removed again
  EXPECT_FALSE(fs::exists(dir_ / "missing"));
  // An existing directory is kept, with only what was there before.
  fs::create_directories(dir_ / "intermediates");
  std::ofstream(dir_ / "intermediates" / "notes.txt") << "mine";
  EXPECT_THROW(bake(o), std::runtime_error);
  ASSERT_TRUE(fs::exists(dir_ / "intermediates"));
  EXPECT_EQ(entries(dir_ / "intermediates"), 1);
}

TEST_F(Bake, TheModelAndTheIntermediatesAppearTogether) {
  BakeOptions o = phantom_options();
  o.intermediates_dir = (dir_ / "intermediates").string();
  o.output_path = (dir_ / "liver.organ").string();
  const BakeResult result = bake(o);
  const model::ModelReadResult read = model::read_organ_model_file(o.output_path);
  ASSERT_TRUE(read) << read.error;
  EXPECT_TRUE(*read.model == result.model);
  EXPECT_TRUE(fs::exists(dir_ / "intermediates" / "tetrahedra.vtu"));
}

TEST_F(Bake, RealCtWithItsLiverLabelNifti) {
  BakeOptions o;
  o.ct_path = (kSamples / "real_ct_totalseg" / "example_ct.nii.gz").string();
  o.label_path = (kSamples / "real_ct_totalseg" / "liver_mask_ct.nii.gz").string();
  o.beams.samples_per_side = 48;
  const BakeResult result = bake(o);
  const BakeReport& r = result.report;
  EXPECT_NEAR(static_cast<double>(r.mask_voxels), 41692.0, 10.0);  // hole filling may add a few
  EXPECT_LT(relative_difference(r.surface_volume_ml, r.mask_volume_ml), 1e-6) << "volume-true surface";
  EXPECT_LT(relative_difference(r.tetrahedra_volume_ml, r.mask_volume_ml), 1e-6) << "volume-true tetrahedra";
  EXPECT_EQ(r.fixed_point_source, "deepest interior point");
  EXPECT_GT(r.fixed_point_depth_mm, 20.0);
  // Decimation left cones here (11 vertices over 45°) before the Laplacian
  // pass after it (none over 45°, at most 45°).
  const Spikes spikes = surface_spikes(result.model);
  EXPECT_LE(spikes.over_45_deg, 2u);
  EXPECT_LT(spikes.largest_deg, 60.0);
  EXPECT_EQ(model::validate_organ_model(result.model), "");
  EXPECT_GE(r.tetrahedra.min_dihedral_deg, kMinDihedralGoalDeg) << "no slivers on a real liver";
  EXPECT_LE(r.tetrahedra.max_radius_edge_ratio, kMaxRadiusEdgeGoal);
  EXPECT_TRUE(r.tetrahedra_warnings.empty());
  EXPECT_GE(clamped_nodes(result.model), 80u) << "the FEM clamp's ball resolved (8 mm cells put 4 nodes in it)";
  EXPECT_EQ(result.model.provenance.parameters.at("clamp_cells_mm"), "2.5");
  EXPECT_DOUBLE_EQ(result.model.meshing.clamp_cell_size, 0.0025);
  EXPECT_DOUBLE_EQ(result.model.meshing.clamp_radius, o.sites.fixed_radius);
  RecordProperty("clamped_nodes", std::to_string(clamped_nodes(result.model)));
  RecordProperty("tet_volume_error", std::to_string(r.tetrahedra_volume_ml / r.mask_volume_ml - 1));
  RecordProperty("min_dihedral_deg", std::to_string(r.tetrahedra.min_dihedral_deg));
  RecordProperty("max_radius_edge_ratio", std::to_string(r.tetrahedra.max_radius_edge_ratio));
}

TEST_F(Bake, RealCtDicomSeriesWithAFlippedLabelMap) {
  BakeOptions o;
  o.ct_path = (kSamples / "real_ct_totalseg" / "example_ct_dicom").string();
  o.label_path = (kSamples / "real_ct_totalseg" / "liver_mask_dicom.nii.gz").string();
  o.beams.samples_per_side = 48;
  const BakeResult result = bake(o);
  const BakeReport& r = result.report;
  EXPECT_EQ(r.image_size, (std::array<std::size_t, 3>{512, 512, 20}));
  EXPECT_NEAR(r.mask_volume_ml, 699.0, 10.0);
  EXPECT_LT(relative_difference(r.surface_volume_ml, r.mask_volume_ml), 1e-6) << "volume-true surface";
  // 2 mm slices: decimating the contour's slice-to-slice ripples left 77
  // cones over 45° (up to 214°) before the Laplacian pass after decimation;
  // one is left away from the field of view's cuts (47°). The cuts are flat
  // faces of the data, and where one meets a ridge the organ has a corner
  // like a cube's (90°): 93° there.
  double low_z = 1e9, high_z = -1e9;
  for (const model::Point3& p : result.model.surface_vertices)
    low_z = std::min(low_z, p[2]), high_z = std::max(high_z, p[2]);
  const auto at_a_cut = [&](const model::Point3& p) { return p[2] < low_z + 0.002 || p[2] > high_z - 0.002; };
  const Spikes inside = surface_spikes(result.model, [&](const model::Point3& p) { return !at_a_cut(p); });
  EXPECT_LE(inside.over_45_deg, 3u);
  EXPECT_LT(inside.largest_deg, 60.0);
  EXPECT_LT(surface_spikes(result.model, at_a_cut).largest_deg, 120.0);
  EXPECT_LT(relative_difference(r.tetrahedra_volume_ml, r.mask_volume_ml), 1e-6) << "volume-true tetrahedra";
  // This liver is cut flat by the field of view at both ends: the worst
  // tetrahedra sit on those creases with all four vertices on the boundary,
  // where only flips and edge splits help (11.95° and 3.68 without them).
  EXPECT_GE(r.tetrahedra.min_dihedral_deg, kMinDihedralGoalDeg) << "no slivers on a real liver";
  EXPECT_LE(r.tetrahedra.max_radius_edge_ratio, kMaxRadiusEdgeGoal);
  EXPECT_TRUE(r.tetrahedra_warnings.empty());
  EXPECT_GE(clamped_nodes(result.model), 80u) << "the FEM clamp's ball resolved (8 mm cells put 4 nodes in it)";
  EXPECT_EQ(result.model.provenance.parameters.at("clamp_cells_mm"), "2.5");
  EXPECT_DOUBLE_EQ(result.model.meshing.clamp_cell_size, 0.0025);
  EXPECT_DOUBLE_EQ(result.model.meshing.clamp_radius, o.sites.fixed_radius);
  RecordProperty("clamped_nodes", std::to_string(clamped_nodes(result.model)));
  RecordProperty("tet_volume_error", std::to_string(r.tetrahedra_volume_ml / r.mask_volume_ml - 1));
  RecordProperty("min_dihedral_deg", std::to_string(r.tetrahedra.min_dihedral_deg));
  RecordProperty("max_radius_edge_ratio", std::to_string(r.tetrahedra.max_radius_edge_ratio));
}

TEST_F(Bake, RealCtFromOneSeedWithoutALabelMap) {
  BakeOptions o;
  o.ct_path = (kSamples / "real_ct_totalseg" / "example_ct.nii.gz").string();
  o.seeded.seeds = {SeedPoint::at_voxel({86, 47, 108})};  // the seed that leaked tenfold before leak control
  o.reference_label_path = (kSamples / "real_ct_totalseg" / "liver_mask_ct.nii.gz").string();
  o.beams.samples_per_side = 48;
  const BakeResult result = bake(o);
  const BakeReport& r = result.report;
  ASSERT_TRUE(r.reference_dice.has_value());
  EXPECT_GE(*r.reference_dice, 0.90);
  ASSERT_TRUE(r.seeded.has_value());
  EXPECT_GT(r.seeded->cut_by_opening_ml, 0.0);
  EXPECT_TRUE(r.segmentation_warnings.empty());
  EXPECT_LT(relative_difference(r.tetrahedra_volume_ml, r.mask_volume_ml), 1e-6);
  EXPECT_GE(r.tetrahedra.min_dihedral_deg, kMinDihedralGoalDeg);
  EXPECT_LE(r.tetrahedra.max_radius_edge_ratio, kMaxRadiusEdgeGoal);
  EXPECT_EQ(model::validate_organ_model(result.model), "");
  EXPECT_NE(result.model.provenance.parameters.at("seeds").find("86,47,108 voxel"), std::string::npos);
  RecordProperty("dice", std::to_string(*r.reference_dice));
  RecordProperty("min_dihedral_deg", std::to_string(r.tetrahedra.min_dihedral_deg));
  RecordProperty("max_radius_edge_ratio", std::to_string(r.tetrahedra.max_radius_edge_ratio));
}

// The DICOM series from a seed: the seeded mask's border is rougher than
// the label's, and the field of view cuts it flat at both ends.
TEST_F(Bake, RealCtDicomSeriesFromOneSeed) {
  BakeOptions o;
  o.ct_path = (kSamples / "real_ct_totalseg" / "example_ct_dicom").string();
  o.seeded.seeds = {SeedPoint::at_voxel({184, 287, 14})};
  o.reference_label_path = (kSamples / "real_ct_totalseg" / "liver_mask_dicom.nii.gz").string();
  o.beams.samples_per_side = 32;
  o.beams.stations = 8;
  const BakeReport r = bake(o).report;
  ASSERT_TRUE(r.reference_dice.has_value());
  EXPECT_GE(*r.reference_dice, 0.90);
  EXPECT_LT(relative_difference(r.tetrahedra_volume_ml, r.mask_volume_ml), 1e-6);
  EXPECT_GE(r.tetrahedra.min_dihedral_deg, kMinDihedralGoalDeg);
  EXPECT_LE(r.tetrahedra.max_radius_edge_ratio, kMaxRadiusEdgeGoal);
  RecordProperty("min_dihedral_deg", std::to_string(r.tetrahedra.min_dihedral_deg));
  RecordProperty("max_radius_edge_ratio", std::to_string(r.tetrahedra.max_radius_edge_ratio));
}

TEST_F(Bake, AwkwardLabelMapBakesIntoAClosedModel) {
  const MaskImage::Pointer mask = testing::make_awkward_mask();
  auto ct = CtImage::New();
  ct->CopyInformation(mask);
  ct->SetRegions(mask->GetLargestPossibleRegion());
  ct->Allocate(true);
  BakeOptions o;
  o.ct_path = (dir_ / "ct.nii.gz").string();
  o.label_path = (dir_ / "label.nii.gz").string();
  write_ct_image(*ct, o.ct_path);
  write_mask_image(*mask, o.label_path);
  o.surface.target_vertices = 800;
  o.tetrahedra.tet_size_mm = 6.0;
  o.beams.stations = 8;
  o.beams.samples_per_side = 32;
  const BakeResult result = bake(o);
  EXPECT_EQ(model::validate_organ_model(result.model), "");
  EXPECT_GT(result.report.tetrahedra.tetrahedra, 100u);
}

void expect_error(const BakeOptions& o, const std::string& fragment) {
  try {
    bake(o);
    ADD_FAILURE() << "no error; expected one mentioning \"" << fragment << "\"";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
  }
}

TEST_F(Bake, BadOptionsAndInputsAreOneLineErrors) {
  BakeOptions o = phantom_options();
  o.seeded.seeds.clear();
  expect_error(o, "no segmentation");
  o = phantom_options();
  o.label_path = (kSamples / "phantom_liver_mask.nii.gz").string();
  expect_error(o, "not both");
  o = phantom_options();
  o.fixed_point_mm = std::array<double, 3>{150.0, 150.0, 90.0};
  expect_error(o, "outside the organ");
  o = phantom_options();
  o.fixed_point_voxel = std::array<long, 3>{500, 0, 0};
  expect_error(o, "outside the image");
  o = phantom_options();
  o.seeded.seeds = {SeedPoint::at_mm({0.0, -100.0, 0.0})};  // visceral fat
  expect_error(o, "lies in fat");
  o = phantom_options();
  o.seeded.seeds = {SeedPoint::at_mm({900.0, 0.0, 0.0})};
  expect_error(o, "outside the volume");
  o = phantom_options();
  o.minimum_voxels = 10'000'000;
  expect_error(o, "voxels");
  o = phantom_options();
  o.label_path = (kSamples / "phantom_liver_mask.nii.gz").string();
  o.seeded.seeds.clear();
  o.label_value = 7;
  expect_error(o, "label value 7");
  o = phantom_options();
  o.label_path = (kSamples / "real_ct_totalseg" / "liver_mask_ct.nii.gz").string();
  o.seeded.seeds.clear();
  expect_error(o, "does not match");
  o = phantom_options();
  o.material.poisson_ratio = 0.5;
  expect_error(o, "--poisson-ratio");
  o = phantom_options();
  o.ct_path = (dir_ / "missing.nii.gz").string();
  expect_error(o, "missing.nii.gz");
}

}  // namespace
}  // namespace organsim::pipeline

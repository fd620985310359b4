// `organsim segment`: the mask on the CT's grid, the report (text and JSON)
// with the Dice against a reference label, several and background seeds, and
// its errors (a seed in air is an input error, a malformed seed a usage error).
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <string>

#include "cli_fixture.h"
#include "organsim/pipeline/ct_input.h"
#include "organsim/pipeline/segmentation.h"

namespace organsim {
namespace {

using namespace cli::testing;

// A function, not a namespace-scope path: kSamples lives in another file.
fs::path real_ct(const char* name) { return kSamples / "real_ct_totalseg" / name; }

TEST_F(Cli, SegmentTheRealCtFromOneSeedAndCompareWithItsLabel) {
  const fs::path mask = dir_ / "liver_mask.nii.gz";
  const std::string label = real_ct("liver_mask_ct.nii.gz").string();
  const CommandRun run = run_organsim("segment " + real_ct("example_ct.nii.gz").string() +
                                          " --seed-voxel 86,47,108 -o " + mask.string() + " --reference " + label,
                                      dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  for (const char* line : {"mask ", "HU window ", "leak control ", "working grid ", "time (segment) ", "Dice "})
    EXPECT_NE(run.out.find(line), std::string::npos) << line << "\n" << run.out;
  // The mask lies on the CT's grid: 3D Slicer overlays it, bake --label takes it.
  const pipeline::CtImage::Pointer ct = pipeline::read_ct(real_ct("example_ct.nii.gz").string());
  const pipeline::MaskImage::Pointer written = pipeline::read_label_mask(mask.string(), 1, *ct);
  EXPECT_GE(pipeline::dice_coefficient(*written, *pipeline::read_label_mask(label, 1, *ct)), 0.90);
}

TEST_F(Cli, SegmentJsonWithSeveralAndBackgroundSeeds) {
  const fs::path mask = dir_ / "mask.nii.gz";
  const CommandRun run =
      run_organsim("segment " + real_ct("example_ct.nii.gz").string() +
                       " --seed-voxel 86,47,108 --seed-voxel 93,61,87 --background-seed-voxel 65,51,106 -o " +
                       mask.string() + " --reference " + real_ct("liver_mask_ct.nii.gz").string() + " --json",
                   dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["mask"], mask.string());
  EXPECT_GE(j["dice"].get<double>(), 0.90);
  const nlohmann::json& s = j["segmentation"];
  EXPECT_NEAR(s["volume_ml"].get<double>(), 1126.0, 0.15 * 1126.0);
  EXPECT_GT(s["background_split_ml"].get<double>(), 0.0);
  EXPECT_GT(s["cut_by_opening_ml"].get<double>(), 0.0);
  EXPECT_LT(s["hu_window"][0].get<double>(), s["organ_median_hu"].get<double>());
  EXPECT_GT(s["hu_window"][1].get<double>(), s["organ_median_hu"].get<double>());
  EXPECT_TRUE(s["warnings"].empty());
  for (const char* step : {"working grid", "smoothing", "window", "background seeds", "leak control",
                           "holes and closing", "what was cut", "CT grid"})
    EXPECT_TRUE(s["seconds"].contains(step)) << step;
}

// What was cut, in the report and as a label map on the CT's grid: the body
// wall the window's region reached, cut by leak control, named with its HU
// (unlike the liver's) and a seed that lies inside it.
TEST_F(Cli, SegmentSaysWhatWasCutAndExplainsItAsALabelMap) {
  const fs::path mask = dir_ / "mask.nii.gz", labels = dir_ / "explain.nii.gz";
  const CommandRun run =
      run_organsim("segment " + real_ct("example_ct.nii.gz").string() + " --seed-voxel 86,47,108 -o " + mask.string() +
                       " --explain " + labels.string() + " --json",
                   dir_);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["explanation"], labels.string());
  const nlohmann::json& regions = j["segmentation"]["cut_regions"];
  ASSERT_FALSE(regions.empty());
  const nlohmann::json& largest = regions[0];
  EXPECT_EQ(largest["cause"], "leak control");
  EXPECT_GT(largest["volume_ml"].get<double>(), 1000.0) << "the body wall and muscles at the liver's HU";
  EXPECT_FALSE(largest["like_organ"].get<bool>());
  for (const char* key : {"median_hu", "sigma_hu", "neck_width_mm", "neck_thickness_mm", "neck_median_hu",
                          "contact_fraction", "depth_mm", "box_mm", "kept_out_because", "seed_mm", "seed_option"})
    EXPECT_TRUE(largest.contains(key)) << key;
  EXPECT_NE(largest["kept_out_because"].get<std::string>().find("HU is not the organ core's"), std::string::npos)
      << largest["kept_out_because"];
  EXPECT_TRUE(j["segmentation"]["taken_back"].is_array()) << "what the neck rule gave back (here nothing)";
  EXPECT_TRUE(j["segmentation"]["taken_back"].empty());
  EXPECT_EQ(largest["seed_option"].get<std::string>().rfind("--seed ", 0), 0u);
  // The label map on the CT's grid: the mask as label 1, the cut as label 2, and the seed inside the cut.
  const pipeline::CtImage::Pointer ct = pipeline::read_ct(real_ct("example_ct.nii.gz").string());
  const pipeline::MaskImage::Pointer organ = pipeline::read_label_mask(labels.string(), 1, *ct);
  EXPECT_DOUBLE_EQ(pipeline::dice_coefficient(*organ, *pipeline::read_label_mask(mask.string(), 1, *ct)), 1.0);
  const pipeline::MaskImage::Pointer cut = pipeline::read_label_mask(labels.string(), 2, *ct);
  pipeline::CtImage::PointType seed;
  for (unsigned k = 0; k < 3; ++k) seed[k] = largest["seed_mm"][k].get<double>();
  pipeline::CtImage::IndexType at;
  ASSERT_TRUE(ct->TransformPhysicalPointToIndex(seed, at));
  EXPECT_EQ(cut->GetPixel(at), 1) << "the printed seed lies in what was cut";
}

TEST_F(Cli, SegmentErrorsSayWhatIsWrong) {
  const std::string ct = real_ct("example_ct.nii.gz").string();
  const fs::path mask = dir_ / "mask.nii.gz";
  struct Case {
    std::string arguments;
    int exit_code;
    std::string fragment;
  };
  for (const Case& c :
       {Case{"--seed-voxel 2,2,60", 1, "lies in air"}, Case{"--seed-voxel 2,2,600", 1, "outside the volume"},
        Case{"--seed 1,2", 2, "X,Y,Z"}, Case{"--seed-voxel 1.5,2,3", 2, "whole voxel indices"},
        Case{"", 2, "at least one point inside the organ"}}) {
    const CommandRun run = run_organsim("segment " + ct + " " + c.arguments + " -o " + mask.string(), dir_);
    EXPECT_EQ(run.exit_code, c.exit_code) << c.arguments << "\n" << run.err;
    EXPECT_NE(run.err.find(c.fragment), std::string::npos) << c.arguments << "\n" << run.err;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
    EXPECT_FALSE(fs::exists(mask)) << c.arguments;
  }
}

}  // namespace
}  // namespace organsim

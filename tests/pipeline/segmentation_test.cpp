#include <gtest/gtest.h>

#include "organsim/pipeline/phantom.h"
#include "organsim/pipeline/segmentation.h"

namespace organsim::pipeline {
namespace {

const Phantom& phantom() {
  static const Phantom p = make_phantom(PhantomOptions{});
  return p;
}

RegionGrowingOptions seeded_in_right_lobe() {
  RegionGrowingOptions o;
  o.seed_voxel = voxel_of_point(*phantom().ct, {-65.0, 5.0, 0.0});
  return o;
}

TEST(Segmentation, RegionGrowingFindsThePhantomLiver) {
  const MaskImage::Pointer mask = segment_by_region_growing(*phantom().ct, seeded_in_right_lobe());
  const double dice = dice_coefficient(*mask, *phantom().liver_mask);
  EXPECT_GE(dice, 0.95);
  RecordProperty("dice", std::to_string(dice));
}

TEST(Segmentation, SeedOutsideTheVolumeOrTheWindowIsAClearError) {
  EXPECT_THROW(
      {
        try {
          voxel_of_point(*phantom().ct, {0.0, 0.0, 900.0});
        } catch (const std::runtime_error& e) {
          EXPECT_NE(std::string(e.what()).find("lies outside the volume"), std::string::npos) << e.what();
          throw;
        }
      },
      std::runtime_error);
  RegionGrowingOptions outside = seeded_in_right_lobe();
  outside.seed_voxel = {-1, 3, 3};
  EXPECT_THROW(segment_by_region_growing(*phantom().ct, outside), std::runtime_error);
  RegionGrowingOptions fat = seeded_in_right_lobe();
  fat.seed_voxel = voxel_of_point(*phantom().ct, {0.0, -100.0, 0.0});  // visceral fat
  try {
    segment_by_region_growing(*phantom().ct, fat);
    FAIL() << "a seed in fat was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("outside the window"), std::string::npos) << e.what();
  }
}

TEST(Segmentation, TinyAndEmptySegmentationsAreErrors) {
  RegionGrowingOptions o = seeded_in_right_lobe();
  o.minimum_voxels = 10000000;
  try {
    segment_by_region_growing(*phantom().ct, o);
    FAIL() << "a tiny segmentation was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("only"), std::string::npos) << e.what();
  }
  auto empty = MaskImage::New();
  empty->SetRegions(phantom().liver_mask->GetLargestPossibleRegion());
  empty->Allocate(true);
  EXPECT_THROW(clean_mask(*empty, 2.0), std::runtime_error);
}

TEST(Segmentation, CleaningKeepsTheLargestComponentAndFillsHoles) {
  auto mask = MaskImage::New();
  MaskImage::RegionType region;
  region.SetSize({{40, 40, 40}});
  mask->SetRegions(region);
  mask->Allocate(true);
  for (long k = 5; k < 30; ++k)
    for (long j = 5; j < 30; ++j)
      for (long i = 5; i < 30; ++i) mask->SetPixel({{i, j, k}}, 1);
  mask->SetPixel({{15, 15, 15}}, 0);  // an interior hole
  mask->SetPixel({{35, 35, 35}}, 1);  // a speck
  const MaskImage::Pointer clean = clean_mask(*mask, 0.0);
  EXPECT_EQ(count_voxels(*clean), 25u * 25u * 25u);
}

}  // namespace
}  // namespace organsim::pipeline

#include <gtest/gtest.h>

#include "organsim/pipeline/phantom.h"
#include "organsim/pipeline/segmentation.h"

namespace organsim::pipeline {
namespace {

const Phantom& phantom() {
  static const Phantom p = make_phantom(PhantomOptions{});
  return p;
}

TEST(Segmentation, EmptyMasksAreErrors) {
  auto empty = MaskImage::New();
  empty->SetRegions(phantom().liver_mask->GetLargestPossibleRegion());
  empty->Allocate(true);
  EXPECT_THROW(clean_mask(*empty, 2.0), std::runtime_error);
  EXPECT_THROW(organ_bounding_box(*empty, {0, 0, 0}), std::runtime_error);
}

TEST(Segmentation, PointsOutsideTheVolumeAreAClearError) {
  try {
    voxel_of_point(*phantom().ct, {0.0, 0.0, 900.0});
    FAIL() << "a point outside the volume was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("lies outside the volume"), std::string::npos) << e.what();
  }
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

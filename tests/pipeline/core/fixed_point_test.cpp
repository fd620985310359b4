// The fixed point stage: the deepest interior point by default, given points
// and voxels checked against the organ.
#include <gtest/gtest.h>

#include <itkImageRegionConstIteratorWithIndex.h>
#include <itkMultiThreaderBase.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "organsim/pipeline/fixed_point.h"
#include "synthetic_volumes.h"

namespace organsim::pipeline {
namespace {

TEST(FixedPoint, DefaultIsTheDeepestInteriorPoint) {
  // A sphere: on an ellipsoid the distance map's ridge is nearly flat.
  testing::Ellipsoid e;
  e.semi_axes_mm = {30.0, 30.0, 30.0};
  const MaskImage::Pointer mask = testing::make_ellipsoid_mask(e, {1.0, 1.0, 1.0});
  const auto [point, depth] = deepest_interior_point(*mask);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(point[k], e.centre_mm[k], 1.5);
  // The depth is the distance to the nearest background voxel, by brute force.
  double nearest = std::numeric_limits<double>::infinity();
  itk::ImageRegionConstIteratorWithIndex<MaskImage> it(mask, mask->GetLargestPossibleRegion());
  for (; !it.IsAtEnd(); ++it)
    if (!it.Get()) {
      MaskImage::PointType p;
      mask->TransformIndexToPhysicalPoint(it.GetIndex(), p);
      nearest = std::min(nearest, std::hypot(p[0] - point[0], p[1] - point[1], p[2] - point[2]));
    }
  EXPECT_NEAR(depth, nearest, 1.0);
  EXPECT_NEAR(depth, e.semi_axes_mm[0], 1.5);
}

TEST(FixedPoint, TheSameWhateverTheThreads) {
  // An irregular organ on an anisotropic grid, whose distance map has many
  // near-ties: the deepest point and its depth do not depend on how many
  // threads compute the map.
  const MaskImage::Pointer mask = testing::make_awkward_mask();
  const int threads = itk::MultiThreaderBase::GetGlobalDefaultNumberOfThreads();
  itk::MultiThreaderBase::SetGlobalDefaultNumberOfThreads(1);
  const auto alone = deepest_interior_point(*mask);
  for (int n : {2, 3, 8}) {
    itk::MultiThreaderBase::SetGlobalDefaultNumberOfThreads(n);
    const auto shared = deepest_interior_point(*mask);
    EXPECT_EQ(shared.first, alone.first) << n << " threads";
    EXPECT_EQ(shared.second, alone.second) << n << " threads";
  }
  itk::MultiThreaderBase::SetGlobalDefaultNumberOfThreads(threads);
}

TEST(FixedPoint, TheDefaultIsReportedAsTheDeepestInteriorPoint) {
  testing::Ellipsoid e;
  e.semi_axes_mm = {20.0, 20.0, 20.0};
  const MaskImage::Pointer mask = testing::make_ellipsoid_mask(e, {1.0, 1.0, 1.0});
  const FixedPoint fixed = choose_fixed_point(*mask, std::nullopt, std::nullopt);
  EXPECT_EQ(fixed.source, "deepest interior point");
  EXPECT_NEAR(fixed.depth_mm, 20.0, 1.5);
  EXPECT_EQ(fixed.outside_mm, 0.0);
}

TEST(FixedPoint, AGivenPointInsideOrJustOutsideTheOrganIsKept) {
  testing::Ellipsoid e;
  e.semi_axes_mm = {20.0, 20.0, 20.0};
  const MaskImage::Pointer mask = testing::make_ellipsoid_mask(e, {1.0, 1.0, 1.0});
  const std::array<double, 3> centre = e.centre_mm;
  const FixedPoint inside = choose_fixed_point(*mask, centre, std::nullopt);
  EXPECT_EQ(inside.source, "given point");
  EXPECT_EQ(inside.point_mm, centre);
  EXPECT_LT(inside.outside_mm, 1.0);  // to the nearest voxel centre: under half a voxel diagonal inside
  // 5 mm beyond the surface along x: within the tolerance for a vessel entry.
  const std::array<double, 3> notch{centre[0] + 25.0, centre[1], centre[2]};
  const FixedPoint outside = choose_fixed_point(*mask, notch, std::nullopt);
  EXPECT_NEAR(outside.outside_mm, 5.0, 1.0);
  EXPECT_NEAR(distance_to_organ_mm(*mask, notch, kFixedPointToleranceMm), outside.outside_mm, 1e-12);
}

TEST(FixedPoint, AGivenVoxelIsTheVoxelCentre) {
  testing::Ellipsoid e;
  e.semi_axes_mm = {20.0, 20.0, 20.0};
  const MaskImage::Pointer mask = testing::make_ellipsoid_mask(e, {1.0, 1.0, 1.0});
  const auto size = mask->GetLargestPossibleRegion().GetSize();
  const std::array<long, 3> voxel{static_cast<long>(size[0] / 2), static_cast<long>(size[1] / 2),
                                  static_cast<long>(size[2] / 2)};
  const FixedPoint fixed = choose_fixed_point(*mask, std::nullopt, voxel);
  EXPECT_EQ(fixed.source, "given voxel");
  MaskImage::IndexType index{{voxel[0], voxel[1], voxel[2]}};
  MaskImage::PointType expected;
  mask->TransformIndexToPhysicalPoint(index, expected);
  for (int k = 0; k < 3; ++k) EXPECT_DOUBLE_EQ(fixed.point_mm[k], expected[k]);
}

TEST(FixedPoint, BadPointsAreOneLineErrorsThatSayWhatToDo) {
  testing::Ellipsoid e;
  e.semi_axes_mm = {20.0, 20.0, 20.0};
  const MaskImage::Pointer mask = testing::make_ellipsoid_mask(e, {1.0, 1.0, 1.0});
  auto message = [&](const std::optional<std::array<double, 3>>& point,
                     const std::optional<std::array<long, 3>>& voxel) {
    try {
      choose_fixed_point(*mask, point, voxel);
    } catch (const std::runtime_error& error) {
      return std::string(error.what());
    }
    return std::string("(no error)");
  };
  const std::array<double, 3> far{e.centre_mm[0] + 40.0, e.centre_mm[1], e.centre_mm[2]};
  EXPECT_NE(message(far, std::nullopt).find("outside the organ"), std::string::npos);
  EXPECT_NE(message(far, std::nullopt).find("omit it"), std::string::npos);
  EXPECT_NE(message(std::nullopt, std::array<long, 3>{-1, 0, 0}).find("outside the image"), std::string::npos);
  EXPECT_NE(message(far, std::array<long, 3>{0, 0, 0}).find("not both"), std::string::npos);
  EXPECT_EQ(message(far, std::nullopt).find('\n'), std::string::npos);
  // Far beyond the search limit the distance only says "farther than the limit".
  EXPECT_GT(distance_to_organ_mm(*mask, far, kFixedPointToleranceMm), kFixedPointToleranceMm);
}

}  // namespace
}  // namespace organsim::pipeline

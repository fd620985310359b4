#include <gtest/gtest.h>

#include <itkImageRegionConstIterator.h>

#include <cstring>

#include "organsim/pipeline/phantom.h"

namespace organsim::pipeline {
namespace {

PhantomOptions small_options() {
  PhantomOptions o;
  o.size = {64, 52, 32};
  o.spacing_mm = {6.0, 6.0, 6.0};
  return o;
}

template <typename Image>
bool same_voxels(const Image& a, const Image& b) {
  const std::size_t n = a.GetLargestPossibleRegion().GetNumberOfPixels();
  return n == b.GetLargestPossibleRegion().GetNumberOfPixels() &&
         std::memcmp(a.GetBufferPointer(), b.GetBufferPointer(), n * sizeof(typename Image::PixelType)) == 0;
}

TEST(Phantom, IsDeterministicForASeedAndVariesWithIt) {
  const Phantom a = make_phantom(small_options());
  const Phantom b = make_phantom(small_options());
  EXPECT_TRUE(same_voxels(*a.ct, *b.ct));
  EXPECT_TRUE(same_voxels(*a.liver_mask, *b.liver_mask));
  EXPECT_EQ(a.fixed_point_mm, b.fixed_point_mm);
  PhantomOptions other = small_options();
  other.seed = 2;
  const Phantom c = make_phantom(other);
  EXPECT_FALSE(same_voxels(*a.ct, *c.ct));
  EXPECT_TRUE(same_voxels(*a.liver_mask, *c.liver_mask));  // noise only
}

TEST(Phantom, HasTheTissuesOfAnAbdominalCt) {
  const Phantom p = make_phantom(PhantomOptions{});
  double liver_sum = 0, liver_sq = 0;
  std::size_t liver = 0, fat = 0, bone = 0, contrast = 0;
  itk::ImageRegionConstIterator<CtImage> ct(p.ct, p.ct->GetLargestPossibleRegion());
  itk::ImageRegionConstIterator<MaskImage> mask(p.liver_mask, p.liver_mask->GetLargestPossibleRegion());
  for (; !ct.IsAtEnd(); ++ct, ++mask) {
    const double hu = ct.Get();
    if (mask.Get()) {
      ++liver;
      liver_sum += hu;
      liver_sq += hu * hu;
    }
    fat += hu > -140 && hu < -60;
    bone += hu >= 300 && hu < 1500;
    contrast += hu > 140 && hu < 220;
  }
  const double mean = liver_sum / liver, sd = std::sqrt(liver_sq / liver - mean * mean);
  EXPECT_GT(mean, 40.0);
  EXPECT_LT(mean, 70.0);
  EXPECT_GT(sd, 5.0);  // noisy, not a plateau
  EXPECT_GT(fat, 100000u);
  EXPECT_GT(bone, 1000u);
  EXPECT_GT(contrast, 1000u);
  EXPECT_NEAR(p.liver_volume_ml, liver * 27.0 / 1000.0, 1e-9);
  EXPECT_GT(p.liver_volume_ml, 1000.0);  // an adult liver: 1.2-1.8 L
  EXPECT_LT(p.liver_volume_ml, 2200.0);
}

TEST(Phantom, FixedPointIsOnTheLiverSurface) {
  const Phantom p = make_phantom(PhantomOptions{});
  // Voxels within one voxel of the fixed point are both inside and outside the liver.
  CtImage::PointType point;
  for (int k = 0; k < 3; ++k) point[k] = p.fixed_point_mm[k];
  const auto index = p.liver_mask->TransformPhysicalPointToIndex(point);
  bool inside = false, outside = false;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        auto i = index;
        i[0] += dx;
        i[1] += dy;
        i[2] += dz;
        (p.liver_mask->GetPixel(i) ? inside : outside) = true;
      }
  EXPECT_TRUE(inside);
  EXPECT_TRUE(outside);
}

TEST(Phantom, IsNonConvex) {
  // The segment between two liver voxels (left lobe tip, caudate lobe) leaves the organ.
  const Phantom p = make_phantom(PhantomOptions{});
  auto inside = [&](double x, double y, double z) {
    CtImage::PointType point;
    point[0] = x;
    point[1] = y;
    point[2] = z;
    return p.liver_mask->GetPixel(p.liver_mask->TransformPhysicalPointToIndex(point)) != 0;
  };
  ASSERT_TRUE(inside(60, -30, 25));
  ASSERT_TRUE(inside(-40, 25, -45));
  bool left_the_organ = false;
  for (double t = 0; t <= 1; t += 0.01) left_the_organ |= !inside(60 - t * 100, -30 + t * 55, 25 - t * 70);
  EXPECT_TRUE(left_the_organ);
}

TEST(Phantom, RejectsUnusableOptions) {
  PhantomOptions o;
  o.size = {8, 64, 64};
  EXPECT_THROW(make_phantom(o), std::invalid_argument);
  o = PhantomOptions{};
  o.spacing_mm[1] = 0;
  EXPECT_THROW(make_phantom(o), std::invalid_argument);
  o = PhantomOptions{};
  o.size = {4096, 4096, 4096};
  EXPECT_THROW(make_phantom(o), std::invalid_argument);
}

}  // namespace
}  // namespace organsim::pipeline

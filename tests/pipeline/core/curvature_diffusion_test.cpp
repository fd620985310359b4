// curvature_diffusion() against ITK's CurvatureAnisotropicDiffusionImageFilter:
// every voxel's bits, on noise (every kind of neighbourhood, the border's
// clamping included), on thin volumes, on the phantom CT (the bake's case),
// with anisotropic spacing, several iteration counts and conductances, and
// on any number of threads.
#include <gtest/gtest.h>

#include <itkCastImageFilter.h>
#include <itkCurvatureAnisotropicDiffusionImageFilter.h>

#include <cstring>
#include <random>

#include "organsim/pipeline/curvature_diffusion.h"
#include "organsim/pipeline/phantom.h"

namespace organsim::pipeline {
namespace {

FloatImage::Pointer itk_smoothed(const FloatImage& image, const CurvatureDiffusionOptions& o) {
  auto filter = itk::CurvatureAnisotropicDiffusionImageFilter<FloatImage, FloatImage>::New();
  filter->SetInput(&image);
  filter->SetNumberOfIterations(o.iterations);
  filter->SetTimeStep(o.time_step);
  filter->SetConductanceParameter(o.conductance);
  filter->Update();
  return filter->GetOutput();
}

/// How many voxels differ in their bits.
std::size_t differing_voxels(const FloatImage& a, const FloatImage& b) {
  const std::size_t n = a.GetLargestPossibleRegion().GetNumberOfPixels();
  EXPECT_EQ(n, b.GetLargestPossibleRegion().GetNumberOfPixels());
  std::size_t differing = 0;
  for (std::size_t v = 0; v < n; ++v)
    differing += std::memcmp(a.GetBufferPointer() + v, b.GetBufferPointer() + v, sizeof(float)) != 0;
  return differing;
}

FloatImage::Pointer noise(const std::array<unsigned, 3>& size, const std::array<double, 3>& spacing, unsigned seed) {
  auto image = FloatImage::New();
  FloatImage::RegionType region;
  for (unsigned k = 0; k < 3; ++k) region.SetSize(k, size[k]);
  image->SetRegions(region);
  FloatImage::SpacingType s;
  for (unsigned k = 0; k < 3; ++k) s[k] = spacing[k];
  image->SetSpacing(s);
  image->Allocate();
  std::mt19937 random(seed);
  std::normal_distribution<float> hu(40.0f, 60.0f);
  const std::size_t n = region.GetNumberOfPixels();
  for (std::size_t v = 0; v < n; ++v) image->GetBufferPointer()[v] = hu(random);
  // A bright block: steep edges, where the conductance cuts the flow.
  for (unsigned z = size[2] / 4; z < size[2] / 2; ++z)
    for (unsigned y = size[1] / 3; y < 2 * size[1] / 3; ++y)
      for (unsigned x = 1; x < size[0] / 2; ++x) image->GetBufferPointer()[(z * size[1] + y) * size[0] + x] += 900.0f;
  return image;
}

TEST(CurvatureDiffusion, EveryVoxelHasItkFiltersBitsOnNoise) {
  for (const auto& spacing : {std::array<double, 3>{1.0, 1.0, 1.0}, std::array<double, 3>{0.8, 1.3, 2.5}}) {
    const FloatImage::Pointer image = noise({23, 17, 11}, spacing, 7);
    for (unsigned iterations : {1u, 5u})
      for (double conductance : {1.0, 3.0}) {
        CurvatureDiffusionOptions o;
        o.iterations = iterations;
        o.conductance = conductance;
        o.time_step = 0.0625 * std::min({spacing[0], spacing[1], spacing[2]});
        const FloatImage::Pointer ours = curvature_diffusion(*image, o);
        const FloatImage::Pointer theirs = itk_smoothed(*image, o);
        EXPECT_EQ(differing_voxels(*ours, *theirs), 0u)
            << iterations << " iterations, conductance " << conductance << ", spacing " << spacing[2];
        EXPECT_EQ(ours->GetSpacing(), image->GetSpacing());
      }
  }
}

TEST(CurvatureDiffusion, ThinVolumesHaveItkFiltersBitsToo) {
  // One or two voxels across: every neighbour beyond the border is clamped.
  for (const auto& size :
       {std::array<unsigned, 3>{9, 7, 1}, std::array<unsigned, 3>{6, 1, 5}, std::array<unsigned, 3>{2, 3, 2}}) {
    const FloatImage::Pointer image = noise(size, {1.0, 1.5, 2.0}, 11);
    CurvatureDiffusionOptions o;
    o.iterations = 3;
    o.conductance = 2.0;
    EXPECT_EQ(differing_voxels(*curvature_diffusion(*image, o), *itk_smoothed(*image, o)), 0u)
        << size[0] << "x" << size[1] << "x" << size[2];
  }
}

TEST(CurvatureDiffusion, ThePhantomCtHasItkFiltersBitsOnAnyNumberOfThreads) {
  PhantomOptions options;
  const Phantom phantom = make_phantom(options);
  auto as_float = itk::CastImageFilter<CtImage, FloatImage>::New();
  as_float->SetInput(phantom.ct);
  as_float->Update();
  const FloatImage::Pointer ct = as_float->GetOutput();
  CurvatureDiffusionOptions o;  // the seeded segmentation's: 5 iterations, time step 0.0625
  o.conductance = 3.0;
  const FloatImage::Pointer theirs = itk_smoothed(*ct, o);
  for (unsigned threads : {1u, 2u, 3u}) {
    o.threads = threads;
    EXPECT_EQ(differing_voxels(*curvature_diffusion(*ct, o), *theirs), 0u) << threads << " threads";
  }
}

TEST(CurvatureDiffusion, NoIterationsIsACopy) {
  const FloatImage::Pointer image = noise({5, 4, 3}, {1.0, 1.0, 1.0}, 3);
  CurvatureDiffusionOptions o;
  o.iterations = 0;
  const FloatImage::Pointer copy = curvature_diffusion(*image, o);
  EXPECT_NE(copy.GetPointer(), image.GetPointer());
  EXPECT_EQ(differing_voxels(*copy, *image), 0u);
}

}  // namespace
}  // namespace organsim::pipeline

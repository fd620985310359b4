// Liver lesions inserted into a real CT, for testing segmentation on the livers
// a surgeon plans on. No public lesion CT with a redistributable expert label
// exists for us, so we make them: spheroids of 10–40 mm, 30–80 HU darker than
// the parenchyma around them, with partial volume at their border and a slight
// enhancing rim, some deep inside the liver and some reaching its surface. The
// label is unchanged (clinical liver labels count lesions as liver), and only
// voxels of the label change, so what surrounds the liver stays as scanned.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include <itkImageRegionConstIteratorWithIndex.h>
#include <itkSignedMaurerDistanceMapImageFilter.h>

#include "organsim/pipeline/ct_image.h"

namespace organsim::pipeline::testing {

struct Lesion {
  std::array<double, 3> centre_mm{};  ///< physical point (LPS)
  std::array<double, 3> semi_axes_mm{};
  std::array<std::array<double, 3>, 3> axes{};  ///< unit principal axes
  double contrast_hu = 0.0;                     ///< darker than the parenchyma by this much
  bool reaches_surface = false;
};

struct LesionOptions {
  std::uint64_t seed = 1;
  int deep = 3;        ///< lesions whose border stays ≥ 3 mm inside the liver
  int at_surface = 3;  ///< lesions whose border reaches the liver's surface
  double min_diameter_mm = 10.0, max_diameter_mm = 40.0;
  double min_contrast_hu = 30.0, max_contrast_hu = 80.0;
  double rim_hu = 15.0, rim_mm = 2.0;  ///< rim just inside the border, this much brighter than the parenchyma
};

struct LesionCt {
  CtImage::Pointer ct;
  std::vector<Lesion> lesions;
  MaskImage::Pointer lesion_mask;  ///< voxels whose centre lies in a lesion
};

/// Distance (mm) to the mask's border, > 0 inside it.
inline itk::Image<float, 3>::Pointer depth_map(const MaskImage& mask) {
  auto filter = itk::SignedMaurerDistanceMapImageFilter<MaskImage, itk::Image<float, 3>>::New();
  filter->SetInput(&mask);
  filter->SetBackgroundValue(0);
  filter->SetUseImageSpacing(true);
  filter->SetSquaredDistance(false);
  filter->SetInsideIsPositive(true);
  filter->Update();
  return filter->GetOutput();
}

namespace detail {

/// Uniform in [0, 1) from the generator's raw output: the same numbers on every
/// standard library (std::uniform_real_distribution is not specified exactly).
inline double uniform(std::mt19937_64& random) { return static_cast<double>(random() >> 11) * 0x1.0p-53; }

/// √Σ(x_k/a_k)² in the lesion's frame: < 1 inside.
inline double spheroid_level(const Lesion& l, const std::array<double, 3>& p) {
  double sum = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double along = (p[0] - l.centre_mm[0]) * l.axes[k][0] + (p[1] - l.centre_mm[1]) * l.axes[k][1] +
                         (p[2] - l.centre_mm[2]) * l.axes[k][2];
    sum += along * along / (l.semi_axes_mm[k] * l.semi_axes_mm[k]);
  }
  return std::sqrt(sum);
}

}  // namespace detail

/// Inserts lesions into `ct` inside `label` (both on the same grid). Centres are
/// drawn at random voxels of the label at the depth each kind needs (distance
/// map), away from the lesions already placed; deterministic for a seed.
inline LesionCt insert_lesions(const CtImage& ct, const MaskImage& label, const LesionOptions& o) {
  const itk::Image<float, 3>::Pointer depth_pointer = depth_map(label);
  const itk::Image<float, 3>& depth = *depth_pointer;

  std::vector<CtImage::IndexType> inside;
  for (itk::ImageRegionConstIteratorWithIndex<MaskImage> it(&label, label.GetLargestPossibleRegion()); !it.IsAtEnd();
       ++it)
    if (it.Get()) inside.push_back(it.GetIndex());

  LesionCt result;
  result.ct = CtImage::New();
  result.ct->CopyInformation(&ct);
  result.ct->SetRegions(ct.GetLargestPossibleRegion());
  result.ct->Allocate();
  std::copy(ct.GetBufferPointer(), ct.GetBufferPointer() + ct.GetLargestPossibleRegion().GetNumberOfPixels(),
            result.ct->GetBufferPointer());
  result.lesion_mask = MaskImage::New();
  result.lesion_mask->CopyInformation(&ct);
  result.lesion_mask->SetRegions(ct.GetLargestPossibleRegion());
  result.lesion_mask->Allocate(true);

  std::mt19937_64 random(o.seed);
  const auto point_of = [&](const CtImage::IndexType& index) {
    CtImage::PointType p;
    ct.TransformIndexToPhysicalPoint(index, p);
    return std::array<double, 3>{p[0], p[1], p[2]};
  };
  for (int n = 0; n < o.deep + o.at_surface; ++n) {
    Lesion lesion;
    lesion.reaches_surface = n >= o.deep;
    const double diameter = o.min_diameter_mm + (o.max_diameter_mm - o.min_diameter_mm) * detail::uniform(random);
    for (int k = 0; k < 3; ++k)
      lesion.semi_axes_mm[k] = 0.5 * diameter * (k == 0 ? 1.0 : 0.8 + 0.4 * detail::uniform(random));
    // A random rotation: Gram–Schmidt on three random directions.
    for (int k = 0; k < 3; ++k) {
      std::array<double, 3> v{};
      for (double& c : v) c = 2.0 * detail::uniform(random) - 1.0;
      for (int j = 0; j < k; ++j) {
        const double along = v[0] * lesion.axes[j][0] + v[1] * lesion.axes[j][1] + v[2] * lesion.axes[j][2];
        for (int c = 0; c < 3; ++c) v[c] -= along * lesion.axes[j][c];
      }
      const double norm = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
      for (int c = 0; c < 3; ++c) lesion.axes[k][c] = v[c] / norm;
    }
    lesion.contrast_hu = o.min_contrast_hu + (o.max_contrast_hu - o.min_contrast_hu) * detail::uniform(random);
    const double largest = *std::max_element(lesion.semi_axes_mm.begin(), lesion.semi_axes_mm.end());
    const double smallest = *std::min_element(lesion.semi_axes_mm.begin(), lesion.semi_axes_mm.end());
    // Deep: the whole spheroid 3 mm inside. At the surface: the centre at a
    // depth below the smallest semi-axis, so the border crosses the surface.
    bool placed = false;
    for (int attempt = 0; attempt < 20000 && !placed; ++attempt) {
      const CtImage::IndexType index = inside[static_cast<std::size_t>(detail::uniform(random) * inside.size())];
      const double d = depth.GetPixel(index);
      if (lesion.reaches_surface ? !(d > 0.5 * smallest && d < 0.9 * smallest) : !(d > largest + 3.0)) continue;
      lesion.centre_mm = point_of(index);
      placed = true;
      for (const Lesion& other : result.lesions) {
        double gap = 0.0;
        for (int c = 0; c < 3; ++c) gap += std::pow(lesion.centre_mm[c] - other.centre_mm[c], 2);
        const double other_largest = *std::max_element(other.semi_axes_mm.begin(), other.semi_axes_mm.end());
        placed &= std::sqrt(gap) > largest + other_largest + 5.0;
      }
    }
    if (!placed) continue;  // the liver has no room for this one
    result.lesions.push_back(lesion);
  }

  // Partial volume: the fraction of each voxel inside the spheroid and inside
  // its rim shell, from 4³ sample points per voxel.
  constexpr int kSamples = 4;
  const auto spacing = ct.GetSpacing();
  const auto direction = ct.GetDirection();
  for (itk::ImageRegionConstIteratorWithIndex<MaskImage> it(&label, label.GetLargestPossibleRegion()); !it.IsAtEnd();
       ++it) {
    if (!it.Get()) continue;
    const std::array<double, 3> centre = point_of(it.GetIndex());
    for (const Lesion& l : result.lesions) {
      const double largest = *std::max_element(l.semi_axes_mm.begin(), l.semi_axes_mm.end());
      double gap = 0.0;
      for (int c = 0; c < 3; ++c) gap += std::pow(centre[c] - l.centre_mm[c], 2);
      if (std::sqrt(gap) > largest + 2.0 * std::max({spacing[0], spacing[1], spacing[2]})) continue;
      const double smallest = *std::min_element(l.semi_axes_mm.begin(), l.semi_axes_mm.end());
      const double rim_level = 1.0 - o.rim_mm / smallest;
      int in_lesion = 0, in_rim = 0;
      for (int a = 0; a < kSamples; ++a)
        for (int b = 0; b < kSamples; ++b)
          for (int c = 0; c < kSamples; ++c) {
            const double offset[3] = {((a + 0.5) / kSamples - 0.5) * spacing[0],
                                      ((b + 0.5) / kSamples - 0.5) * spacing[1],
                                      ((c + 0.5) / kSamples - 0.5) * spacing[2]};
            std::array<double, 3> p = centre;
            for (int r = 0; r < 3; ++r)
              for (int k = 0; k < 3; ++k) p[r] += direction[r][k] * offset[k];
            const double level = detail::spheroid_level(l, p);
            in_lesion += level < 1.0;
            in_rim += level < 1.0 && level >= rim_level;
          }
      if (in_lesion == 0) continue;
      const double total = kSamples * kSamples * kSamples;
      // The core darker by the contrast, the rim brighter than the parenchyma.
      const double change = (-l.contrast_hu * (in_lesion - in_rim) + o.rim_hu * in_rim) / total;
      const auto index = it.GetIndex();
      result.ct->SetPixel(index, static_cast<CtImage::PixelType>(std::lround(ct.GetPixel(index) + change)));
      if (detail::spheroid_level(l, centre) < 1.0) result.lesion_mask->SetPixel(index, 1);
    }
  }
  return result;
}

}  // namespace organsim::pipeline::testing

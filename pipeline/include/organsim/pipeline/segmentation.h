// Stage 2 of the pipeline: the organ mask. Either imported (see
// read_label_mask in ct_input.h) or grown from a seed in a Hounsfield window,
// then cleaned: hole filling, morphological closing, largest component.
#pragma once

#include <array>
#include <cstddef>

#include "organsim/pipeline/ct_image.h"

namespace organsim::pipeline {

struct RegionGrowingOptions {
  std::array<long, 3> seed_voxel{};    ///< voxel index (i, j, k) of the seed
  double hu_low = 0.0;                 ///< liver default: excludes fat (≈ −100 HU)
  double hu_high = 150.0;              ///< liver default: excludes contrast vessels (≥ 170 HU) and bone
  double closing_radius_mm = 3.0;      ///< morphological closing ball radius
  std::size_t minimum_voxels = 1000;   ///< smaller results are an error ("tiny segmentation")
};

/// Converts a physical point (LPS, mm) to the voxel holding it; throws
/// std::runtime_error when the point is outside the volume.
std::array<long, 3> voxel_of_point(const CtImage& ct, const std::array<double, 3>& point_mm);

/// Seeded region growing (connected threshold) followed by hole filling,
/// closing and keep-largest-component. Throws std::runtime_error with one line
/// when the seed is outside the volume or the HU window, or the result is tiny.
MaskImage::Pointer segment_by_region_growing(const CtImage& ct, const RegionGrowingOptions& options);

/// Hole filling, closing (radius in mm, 0 for none) and keep-largest-component,
/// also applied to imported label maps. Throws when the mask is empty.
MaskImage::Pointer clean_mask(const MaskImage& mask, double closing_radius_mm);

/// The smallest region holding every organ voxel, grown by `margin` voxels per
/// axis and clipped to the image. Throws std::runtime_error when the mask is empty.
MaskImage::RegionType organ_bounding_box(const MaskImage& mask, const std::array<long, 3>& margin);

/// Number of voxels set in a mask.
std::size_t count_voxels(const MaskImage& mask);

/// Dice coefficient 2|A∩B| / (|A|+|B|) of two masks on the same grid.
double dice_coefficient(const MaskImage& a, const MaskImage& b);

}  // namespace organsim::pipeline

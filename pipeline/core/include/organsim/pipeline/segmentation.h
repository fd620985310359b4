// Stage 2 of the pipeline, the tools every mask shares: cleaning an imported
// label map (see read_label_mask in ct_input.h; masks grown from seeds come
// from seeded_segmentation.h), measuring a mask and comparing two.
#pragma once

#include <array>
#include <cstddef>

#include "organsim/pipeline/ct_image.h"

namespace organsim::pipeline {

/// Converts a physical point (LPS, mm) to the voxel holding it; throws
/// std::runtime_error when the point is outside the volume.
std::array<long, 3> voxel_of_point(const CtImage& ct, const std::array<double, 3>& point_mm);

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

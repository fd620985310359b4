// A synthetic abdominal CT with a liver-like organ, for tests, demos and
// benchmarks where a real CT cannot be shipped.
//
// Anatomy (LPS, millimetres, the volume centred on the origin): an elliptic
// body of subcutaneous and visceral fat (≈ −100 HU) inside a skin line, a muscle
// wall (≈ 50 HU), ribs and the spine (bone ≥ 300 HU), a right kidney (≈ 30 HU),
// and a liver on the patient's right: a smooth union of three ellipsoids with a
// low-frequency surface perturbation (non-convex, lobed; ≈ 55 HU plus noise).
// A contrast-filled portal vein (≈ 180 HU) enters the liver from below; where
// its axis crosses the liver surface is the natural fixed point of the model.
#pragma once

#include <array>
#include <cstdint>

#include "organsim/pipeline/ct_image.h"

namespace organsim::pipeline {

struct PhantomOptions {
  std::array<unsigned, 3> size{128, 104, 64};       ///< voxels (columns, rows, slices)
  std::array<double, 3> spacing_mm{3.0, 3.0, 3.0};  ///< voxel size, mm
  std::uint64_t seed = 1;                           ///< noise seed; same seed, same image
  double noise_sigma_hu = 10.0;                     ///< Gaussian noise standard deviation, HU
};

struct Phantom {
  CtImage::Pointer ct;                   ///< Hounsfield units
  MaskImage::Pointer liver_mask;         ///< ground truth: 1 where the voxel centre is in the liver
  std::array<double, 3> fixed_point_mm;  ///< portal vein axis ∩ liver surface, LPS, mm
  double liver_volume_ml = 0.0;          ///< analytic-ish: voxel count × voxel volume, mL
};

/// Builds the phantom. Throws std::invalid_argument when the size or spacing is
/// unusable (fewer than 16 voxels along an axis, non-positive or non-finite
/// spacing, more than 2^31 voxels) with a message naming the option.
Phantom make_phantom(const PhantomOptions& options);

}  // namespace organsim::pipeline

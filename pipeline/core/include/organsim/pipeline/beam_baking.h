// Stage 5 of the pipeline: beam section tables. For every simulation-surface
// vertex v, the beam from the fixed point f to v is cut into N equal elements;
// at each element's midpoint the organ is cut by the plane perpendicular to the
// beam, and the connected piece of that section containing (or nearest to) the
// axis point gives A, I_yy, I_zz, I_yz, J and the centroid offset in the beam
// frame of beam_frame.h (see docs/model-format.md).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <vector>

#include "organsim/model/beam_frame.h"
#include "organsim/model/organ_model.h"
#include "organsim/pipeline/ct_image.h"

namespace organsim::pipeline {

struct BeamBakingOptions {
  std::uint32_t stations = 20;
  unsigned samples_per_side = 96;  ///< section grid resolution over the organ's extent
  unsigned threads = 0;            ///< 0: one per hardware thread
};

/// Samples a binary mask in physical space (metres) with trilinear interpolation.
class MaskSampler {
 public:
  using Index = std::array<double, 3>;  ///< continuous voxel index (i, j, k)

  explicit MaskSampler(const MaskImage& mask);
  /// Interpolated mask value in [0, 1]; 0 outside the volume.
  double value(const model::Point3& point_m) const;
  /// The continuous voxel index of a point (m); affine in the point.
  Index index_of(const model::Point3& point_m) const;
  /// Whether the interpolated value at a continuous index is at least 1/2.
  /// Fast: blocks of 4³ voxels that are uniformly in or out answer without
  /// interpolating, and most samples of an organ section fall in such blocks.
  bool inside(const Index& index) const;
  /// Centre and radius (m) of a sphere containing every voxel of the organ.
  const model::Point3& organ_centre() const { return centre_; }
  double organ_radius() const { return radius_; }

 private:
  double value_at(const Index& index) const;

  const MaskImage& mask_;
  double to_index_[3][3];  // physical (m) → continuous index
  double offset_[3];
  long size_[3];
  long blocks_[3];                   // number of 4³ blocks per axis
  std::vector<std::uint8_t> block_;  // kEmpty, kFull or kMixed for the 5³ voxels a block's samples touch
  // Per mixed block, its 5³ voxels as bits (x fastest), so that a sample near
  // the organ's boundary reads a few cached words instead of the mask, whose
  // scattered bytes a section plane would fetch from memory one line each.
  std::vector<std::uint32_t> mixed_of_block_;  // block → index into mixed_bits_
  std::vector<std::array<std::uint64_t, 2>> mixed_bits_;
  model::Point3 centre_{};
  double radius_ = 0.0;
};

/// The organ section through `axis_point` (m) perpendicular to frame.x.
model::BeamSection organ_section(const MaskSampler& sampler, const model::Point3& axis_point,
                                 const model::BeamFrame& frame, unsigned samples_per_side);

/// Beam tables for every surface vertex (m), multithreaded; deterministic
/// regardless of the thread count. `progress`, when given, is called on the
/// calling thread with the fraction of beams done.
model::BeamTables bake_beam_tables(const MaskImage& mask, const std::vector<model::Point3>& surface_vertices,
                                   const model::Point3& fixed_point, const BeamBakingOptions& options,
                                   const std::function<void(double)>& progress = {});

}  // namespace organsim::pipeline

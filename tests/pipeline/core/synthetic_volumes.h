// Synthetic volumes with analytic geometry for pipeline tests: an ellipsoid on
// a grid with anisotropic spacing, a rotated direction matrix and an offset
// origin, so that every stage is checked in true physical space.
#pragma once

#include <array>
#include <cmath>

#include <itkImageRegionIteratorWithIndex.h>

#include "organsim/pipeline/ct_image.h"

namespace organsim::pipeline::testing {

struct Ellipsoid {
  std::array<double, 3> centre_mm{-12.0, 20.0, 95.0};
  std::array<double, 3> semi_axes_mm{60.0, 40.0, 30.0};
  /// Principal axes (unit, orthonormal): a rotation of the world axes.
  std::array<std::array<double, 3>, 3> axes{};

  /// Principal axes rotated about z by `about_z`, then about x by `about_x` (radians).
  explicit Ellipsoid(double about_z = 0.4, double about_x = 0.25) {
    const double c = std::cos(about_z), s = std::sin(about_z), c2 = std::cos(about_x), s2 = std::sin(about_x);
    axes[0] = {c, s * c2, s * s2};
    axes[1] = {-s, c * c2, c * s2};
    axes[2] = {0.0, -s2, c2};
  }
  bool contains(const std::array<double, 3>& p) const {
    double sum = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double along =
          (p[0] - centre_mm[0]) * axes[k][0] + (p[1] - centre_mm[1]) * axes[k][1] + (p[2] - centre_mm[2]) * axes[k][2];
      sum += along * along / (semi_axes_mm[k] * semi_axes_mm[k]);
    }
    return sum <= 1.0;
  }
  double volume_mm3() const { return 4.0 / 3.0 * M_PI * semi_axes_mm[0] * semi_axes_mm[1] * semi_axes_mm[2]; }
  /// Signed distance from the surface to first order, (f − 1) / |∇f| with
  /// f = √Σ(x_k/a_k)²: exact on the axes, within a few per cent of the true
  /// distance for points within a millimetre of these ellipsoids; mm.
  double signed_distance_mm(const std::array<double, 3>& p) const {
    double f2 = 0.0, g2 = 0.0;
    for (int k = 0; k < 3; ++k) {
      const double along =
          (p[0] - centre_mm[0]) * axes[k][0] + (p[1] - centre_mm[1]) * axes[k][1] + (p[2] - centre_mm[2]) * axes[k][2];
      const double a2 = semi_axes_mm[k] * semi_axes_mm[k];
      f2 += along * along / a2;
      g2 += along * along / (a2 * a2);
    }
    const double f = std::sqrt(f2);
    return (f - 1.0) / (std::sqrt(g2) / f);
  }
};

/// A grid with spacing (0.9, 1.1, 1.6) mm and a direction matrix rotated about
/// z by 0.3 rad, covering the ellipsoid with a margin.
template <typename Image>
typename Image::Pointer make_grid(const Ellipsoid& e, std::array<double, 3> spacing = {0.9, 1.1, 1.6}) {
  auto image = Image::New();
  typename Image::RegionType region;
  typename Image::SpacingType s;
  typename Image::DirectionType direction;
  typename Image::PointType origin;
  const double c = std::cos(0.3), sn = std::sin(0.3);
  direction.SetIdentity();
  direction[0][0] = c, direction[0][1] = -sn, direction[1][0] = sn, direction[1][1] = c;
  const double extent = 2.0 * e.semi_axes_mm[0] + 16.0;
  for (unsigned k = 0; k < 3; ++k) {
    region.SetSize(k, static_cast<itk::SizeValueType>(std::ceil(extent / spacing[k])));
    s[k] = spacing[k];
  }
  // Origin so that the grid centre is the ellipsoid centre.
  for (unsigned r = 0; r < 3; ++r) {
    origin[r] = e.centre_mm[r];
    for (unsigned k = 0; k < 3; ++k) origin[r] -= direction[r][k] * 0.5 * (region.GetSize(k) - 1) * spacing[k];
  }
  image->SetRegions(region);
  image->SetSpacing(s);
  image->SetDirection(direction);
  image->SetOrigin(origin);
  image->Allocate(true);
  return image;
}

inline MaskImage::Pointer make_ellipsoid_mask(const Ellipsoid& e, std::array<double, 3> spacing = {0.9, 1.1, 1.6}) {
  auto mask = make_grid<MaskImage>(e, spacing);
  itk::ImageRegionIteratorWithIndex<MaskImage> it(mask, mask->GetLargestPossibleRegion());
  for (; !it.IsAtEnd(); ++it) {
    MaskImage::PointType p;
    mask->TransformIndexToPhysicalPoint(it.GetIndex(), p);
    it.Set(e.contains({p[0], p[1], p[2]}) ? 1 : 0);
  }
  return mask;
}

/// An empty mask of `size` voxels, `spacing_mm` apart in every direction,
/// the first voxel's centre at `origin_mm`.
inline MaskImage::Pointer blank_mask(const std::array<itk::SizeValueType, 3>& size, double spacing_mm,
                                     const std::array<double, 3>& origin_mm = {0.0, 0.0, 0.0}) {
  auto mask = MaskImage::New();
  MaskImage::RegionType region;
  region.SetSize({{size[0], size[1], size[2]}});
  mask->SetRegions(region);
  MaskImage::SpacingType spacing;
  spacing.Fill(spacing_mm);
  mask->SetSpacing(spacing);
  MaskImage::PointType origin;
  for (unsigned k = 0; k < 3; ++k) origin[k] = origin_mm[k];
  mask->SetOrigin(origin);
  mask->Allocate(true);
  return mask;
}

/// A mask with what breaks marching cubes and decimation: two blocks joined by
/// a one-voxel bridge, a handle (a ring on the first block), an interior
/// cavity, a tunnel, a one-voxel spike, and voxels that touch the organ only
/// along an edge or at a corner.
inline MaskImage::Pointer make_awkward_mask() {
  auto mask = blank_mask({90, 60, 60}, 1.5);
  const auto set = [&](long i, long j, long k) { mask->SetPixel({{i, j, k}}, 1); };
  const auto block = [&](long i0, long i1, long j0, long j1, long k0, long k1) {
    for (long k = k0; k < k1; ++k)
      for (long j = j0; j < j1; ++j)
        for (long i = i0; i < i1; ++i) set(i, j, k);
  };
  block(8, 36, 12, 44, 12, 44);                   // first block
  block(52, 80, 14, 42, 14, 42);                  // second block
  for (long i = 36; i < 52; ++i) set(i, 28, 28);  // one-voxel bridge
  for (long k = 44; k < 52; ++k) set(66, 28, k);  // one-voxel spike
  for (long k = 20; k < 36; ++k)                  // a tunnel through the second block
    for (long j = 24; j < 32; ++j)
      for (long i = 14 + 52; i < 16 + 52; ++i) mask->SetPixel({{i, j, k}}, 0);
  for (long k = 24; k < 30; ++k)  // an interior cavity in the first block
    for (long j = 24; j < 30; ++j)
      for (long i = 18; i < 24; ++i) mask->SetPixel({{i, j, k}}, 0);
  for (int a = 0; a < 360; ++a) {  // a ring standing on the first block
    const double t = a * M_PI / 180.0;
    const long i = 22 + std::lround(10.0 * std::cos(t)), k = 44 + std::lround(10.0 * std::sin(t));
    if (k >= 44) block(i, i + 2, 26, 30, k, k + 2);
  }
  set(7, 11, 20);   // touches the first block along an edge only
  set(36, 44, 44);  // touches it at a corner only
  return mask;
}

}  // namespace organsim::pipeline::testing

#include <gtest/gtest.h>

#include <itkImageRegionIteratorWithIndex.h>

#include <cmath>
#include <random>

#include "organsim/pipeline/beam_baking.h"
#include "synthetic_volumes.h"

namespace organsim::pipeline {
namespace {

model::Point3 metres(const std::array<double, 3>& mm) { return {mm[0] * 1e-3, mm[1] * 1e-3, mm[2] * 1e-3}; }

/// A beam along principal axis `axis` of the ellipsoid through its centre: the
/// sections are ellipses with semi-axes scaled by sqrt(1 − x²/a²). Returns the
/// number of interior stations compared with the analytic values.
int check_principal_axis_beam(int axis) {
  const testing::Ellipsoid e;
  const MaskImage::Pointer mask = testing::make_ellipsoid_mask(e);
  const double a = e.semi_axes_mm[axis];
  const double b = e.semi_axes_mm[(axis + 1) % 3], c = e.semi_axes_mm[(axis + 2) % 3];
  const auto& u = e.axes[axis];
  const std::array<double, 3> from_mm{e.centre_mm[0] - 0.8 * a * u[0], e.centre_mm[1] - 0.8 * a * u[1],
                                      e.centre_mm[2] - 0.8 * a * u[2]};
  const std::array<double, 3> to_mm{e.centre_mm[0] + a * u[0], e.centre_mm[1] + a * u[1], e.centre_mm[2] + a * u[2]};
  BeamBakingOptions options;
  options.stations = 18;
  options.samples_per_side = 160;
  const model::BeamTables tables = bake_beam_tables(*mask, {metres(to_mm)}, metres(from_mm), options);
  int checked = 0;
  for (std::uint32_t s = 0; s < options.stations; ++s) {
    const double t = (s + 0.5) / options.stations;
    const double x = -0.8 * a + t * 1.8 * a;  // mm along the axis from the centre
    if (std::abs(x) > 0.75 * a) continue;     // interior stations only
    const double scale = std::sqrt(1.0 - x * x / (a * a));
    const double bs = b * scale * 1e-3, cs = c * scale * 1e-3;  // m
    const model::BeamSection& section = tables.at(0, s);
    const double area = M_PI * bs * cs;
    EXPECT_NEAR(section.area, area, 0.03 * area) << "axis " << axis << " station " << s;
    // Principal second moments (frame independent): π b c³/4 and π b³ c/4.
    const double mean = 0.5 * (section.i_yy + section.i_zz);
    const double radius = std::hypot(0.5 * (section.i_yy - section.i_zz), section.i_yz);
    const double i_min = M_PI * std::pow(std::min(bs, cs), 3) * std::max(bs, cs) / 4.0;
    const double i_max = M_PI * std::pow(std::max(bs, cs), 3) * std::min(bs, cs) / 4.0;
    EXPECT_NEAR(mean - radius, i_min, 0.03 * i_min) << "axis " << axis << " station " << s;
    EXPECT_NEAR(mean + radius, i_max, 0.03 * i_max) << "axis " << axis << " station " << s;
    const double j = M_PI * std::pow(bs * cs, 3) / (bs * bs + cs * cs);
    EXPECT_NEAR(section.torsion_j, j, 0.05 * j);
    // The beam runs through the centre, so every section is centred on the axis.
    EXPECT_NEAR(std::hypot(section.centroid_y, section.centroid_z), 0.0, 0.02 * std::min(bs, cs));
    ++checked;
  }
  return checked;
}

TEST(BeamBaking, EllipsoidSectionsAlongTheLongAxis) { EXPECT_GE(check_principal_axis_beam(0), 10); }
TEST(BeamBaking, EllipsoidSectionsAlongTheMiddleAxis) { EXPECT_GE(check_principal_axis_beam(1), 10); }
TEST(BeamBaking, EllipsoidSectionsAlongTheShortAxis) { EXPECT_GE(check_principal_axis_beam(2), 10); }

TEST(BeamBaking, UsesTheConnectedPieceNearestTheAxis) {
  // Two separate balls side by side: a section through one must not include the other.
  testing::Ellipsoid e;
  e.semi_axes_mm = {20.0, 20.0, 20.0};
  auto mask = testing::make_grid<MaskImage>(e, {1.0, 1.0, 1.0});
  itk::ImageRegionIteratorWithIndex<MaskImage> it(mask, mask->GetLargestPossibleRegion());
  for (; !it.IsAtEnd(); ++it) {
    MaskImage::PointType p;
    mask->TransformIndexToPhysicalPoint(it.GetIndex(), p);
    const double dx = p[0] - e.centre_mm[0], dy = p[1] - e.centre_mm[1], dz = p[2] - e.centre_mm[2];
    const bool left = std::hypot(dx + 15.0, dy, dz) < 12.0, right = std::hypot(dx - 15.0, dy, dz) < 12.0;
    it.Set(left || right ? 1 : 0);
  }
  const MaskSampler sampler(*mask);
  model::BeamFrame frame;
  const model::Point3 centre = metres({e.centre_mm[0] - 15.0, e.centre_mm[1], e.centre_mm[2]});
  ASSERT_TRUE(model::make_beam_frame(centre, {centre[0], centre[1] + 0.01, centre[2]}, frame));
  const model::BeamSection s = organ_section(sampler, centre, frame, 200);
  EXPECT_NEAR(s.area, M_PI * 0.012 * 0.012, 0.04 * M_PI * 0.012 * 0.012);
}

TEST(BeamBaking, IsDeterministicAcrossThreadCounts) {
  const testing::Ellipsoid e;
  const MaskImage::Pointer mask = testing::make_ellipsoid_mask(e, {2.0, 2.0, 2.0});
  std::vector<model::Point3> vertices;
  for (int k = 0; k < 12; ++k)
    vertices.push_back(metres(
        {e.centre_mm[0] + 25.0 * std::cos(k), e.centre_mm[1] + 25.0 * std::sin(k), e.centre_mm[2] + 2.0 * k - 10.0}));
  BeamBakingOptions one, two;
  one.threads = 1;
  two.threads = 2;
  one.samples_per_side = two.samples_per_side = 48;
  EXPECT_TRUE(bake_beam_tables(*mask, vertices, metres(e.centre_mm), one) ==
              bake_beam_tables(*mask, vertices, metres(e.centre_mm), two));
}

// inside() answers from its block table and, near the boundary, from each
// mixed block's voxel bits: it must say exactly what the interpolated value
// says, at every kind of sample (whole blocks, mixed ones, the volume's edge).
TEST(BeamBaking, InsideAgreesWithTheInterpolatedValueEverywhere) {
  const testing::Ellipsoid e;
  const MaskImage::Pointer mask = testing::make_ellipsoid_mask(e, {1.7, 1.3, 2.1});
  const MaskSampler sampler(*mask);
  const auto size = mask->GetLargestPossibleRegion().GetSize();
  std::mt19937 random(7);
  int boundary = 0;
  for (int n = 0; n < 400000; ++n) {
    MaskSampler::Index index;
    for (int r = 0; r < 3; ++r)
      index[r] = std::uniform_real_distribution<double>(-1.5, static_cast<double>(size[r]) + 0.5)(random);
    // Sample the interpolated value at the same continuous index.
    MaskImage::PointType p;
    mask->TransformContinuousIndexToPhysicalPoint(itk::ContinuousIndex<double, 3>(index.data()), p);
    const double value = sampler.value({p[0] * 1e-3, p[1] * 1e-3, p[2] * 1e-3});
    const MaskSampler::Index again = sampler.index_of({p[0] * 1e-3, p[1] * 1e-3, p[2] * 1e-3});
    ASSERT_EQ(sampler.inside(again), value >= 0.5) << index[0] << ", " << index[1] << ", " << index[2];
    boundary += value > 0.0 && value < 1.0;
  }
  EXPECT_GT(boundary, 1000);  // the boundary's samples, where the bits answer, were tried
}

}  // namespace
}  // namespace organsim::pipeline

// Supports found in a CT (pipeline/supports.h): a block of organ lying on a
// slab of muscle in fat, on grids of several spacings and orientations; the
// face on the muscle is supported, the faces in fat are free, the surface
// about the clamp is attached, and a face cut by the field of view is unseen.
#include <gtest/gtest.h>

#include <itkImageRegionIteratorWithIndex.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <utility>
#include <vector>
#include <stdexcept>

#include <Eigen/Core>
#include <fmt/format.h>

#include "organsim/model/organ_model.h"
#include "organsim/pipeline/phantom.h"
#include "organsim/pipeline/supports.h"
#include "organsim/pipeline/surface.h"
#include "synthetic_volumes.h"

namespace organsim::pipeline {
namespace {

/// The organ: a box 80 × 60 × 50 mm (60 HU) centred at the origin; below it
/// (−z) a slab of muscle 20 mm thick (50 HU) that touches its lower face; fat
/// (−100 HU) elsewhere. With `cut_at_top`, the CT's field of view ends at the
/// box's upper face.
struct BlockOnMuscle {
  CtImage::Pointer ct;
  MaskImage::Pointer mask;
};

BlockOnMuscle block_on_muscle(const std::array<double, 3>& spacing, double rotation_rad, bool cut_at_top = false) {
  testing::Ellipsoid extent;  // only for the grid: centre 0, a margin of 16 mm beyond 2 × 60 mm
  extent.centre_mm = {0.0, 0.0, 0.0};
  extent.semi_axes_mm = {60.0, 60.0, 60.0};
  BlockOnMuscle b;
  b.ct = testing::make_grid<CtImage>(extent, spacing);
  auto direction = b.ct->GetDirection();
  direction.SetIdentity();
  direction[0][0] = std::cos(rotation_rad), direction[0][1] = -std::sin(rotation_rad);
  direction[1][0] = std::sin(rotation_rad), direction[1][1] = std::cos(rotation_rad);
  b.ct->SetDirection(direction);
  CtImage::PointType origin;  // the grid's centre at the origin
  for (unsigned r = 0; r < 3; ++r) {
    origin[r] = 0.0;
    for (unsigned k = 0; k < 3; ++k)
      origin[r] -= direction[r][k] * 0.5 * (b.ct->GetLargestPossibleRegion().GetSize(k) - 1) * spacing[k];
  }
  b.ct->SetOrigin(origin);
  if (cut_at_top) {
    // The field of view's last slice a little above the box's upper face.
    auto region = b.ct->GetLargestPossibleRegion();
    const double top_mm = 25.0 + 0.4 * spacing[2];
    const auto origin_z = b.ct->GetOrigin()[2];
    region.SetSize(2, static_cast<itk::SizeValueType>(std::floor((top_mm - origin_z) / spacing[2])) + 1);
    auto cropped = CtImage::New();
    cropped->CopyInformation(b.ct);
    cropped->SetRegions(region);
    cropped->Allocate();
    b.ct = cropped;
  }
  b.mask = MaskImage::New();
  b.mask->CopyInformation(b.ct);
  b.mask->SetRegions(b.ct->GetLargestPossibleRegion());
  b.mask->Allocate(true);
  itk::ImageRegionIteratorWithIndex<CtImage> it(b.ct, b.ct->GetLargestPossibleRegion());
  for (; !it.IsAtEnd(); ++it) {
    CtImage::PointType p;
    b.ct->TransformIndexToPhysicalPoint(it.GetIndex(), p);
    const bool box = std::abs(p[0]) <= 40.0 && std::abs(p[1]) <= 30.0 && std::abs(p[2]) <= 25.0;
    const bool muscle = std::abs(p[0]) <= 55.0 && std::abs(p[1]) <= 45.0 && p[2] < -25.0 && p[2] >= -45.0;
    it.Set(static_cast<short>(box ? 60 : muscle ? 50 : -100));
    if (box) b.mask->SetPixel(it.GetIndex(), 1);
  }
  return b;
}

model::OrganModel model_of(const MaskImage& mask, const std::array<double, 3>& fixed_point_mm) {
  SurfaceOptions options;
  options.target_vertices = 2000;
  const geometry::SurfaceMesh surface = extract_surface(mask, options);
  model::OrganModel m;
  m.surface_vertices = surface.vertices;
  m.surface_triangles = surface.triangles;
  m.fixed_points = {{fixed_point_mm[0] * 1e-3, fixed_point_mm[1] * 1e-3, fixed_point_mm[2] * 1e-3}};
  m.material = model::liver_default_material();
  return m;
}

double z_mm(const model::OrganModel& m, std::size_t v) { return m.surface_vertices[v][2] * 1e3; }

TEST(Supports, TheFaceOnTheMuscleIsSupportedAndTheFacesInFatAreFree) {
  for (const auto& [spacing, rotation] : {std::pair<std::array<double, 3>, double>{{1.0, 1.0, 1.0}, 0.0},
                                          {{0.9, 1.1, 1.6}, 0.3},
                                          {{2.0, 2.0, 3.0}, -0.5}}) {
    const BlockOnMuscle b = block_on_muscle(spacing, rotation);
    // The clamp deep inside, 20 mm above the lower face's centre: the
    // attachments lie about the surface point nearest it, on the lower face.
    const model::OrganModel m = model_of(*b.mask, {0.0, 0.0, -5.0});
    SupportOptions o;
    SupportReport report;
    const model::Supports supports = find_supports(*b.ct, m, o, &report);
    ASSERT_EQ(supports.vertices.size(), m.surface_vertices.size());
    EXPECT_EQ(model::validate_organ_model([&] {
                model::OrganModel with = m;
                with.tetrahedra.clear();
                with.supports = supports;
                return with;
              }()),
              "");
    std::size_t lower = 0, lower_supported = 0, other = 0, other_supported = 0;
    for (std::size_t v = 0; v < m.surface_vertices.size(); ++v) {
      const bool supported = supports.kind(v) != model::Supports::Kind::kFree;
      // Away from the edges, where the normal turns.
      const bool on_lower_face = z_mm(m, v) < -23.0 && std::abs(m.surface_vertices[v][0]) < 0.035 &&
                                 std::abs(m.surface_vertices[v][1]) < 0.025;
      const bool off_it = z_mm(m, v) > -15.0;
      if (on_lower_face) ++lower, lower_supported += supported;
      if (off_it) ++other, other_supported += supported;
      if (supported) {
        EXPECT_EQ(supports.modulus(v), report.modulus);
      }
      if (supports.kind(v) == model::Supports::Kind::kAttachment) {
        EXPECT_LT(z_mm(m, v), -20.0) << "attached on the lower face";
      }
    }
    RecordProperty(fmt::format("spacing_{}_{}_{}_mm", spacing[0], spacing[1], spacing[2]),
                   fmt::format("contact {:.1f} cm2, attachment {:.1f} cm2, {} of {} lower-face vertices supported",
                               report.contact_area_cm2, report.attachment_area_cm2, lower_supported, lower));
    ASSERT_GT(lower, 20u);
    EXPECT_EQ(lower_supported, lower) << spacing[2] << " mm slices";
    EXPECT_EQ(other_supported, 0u) << "of " << other << " vertices in fat";
    // The lower face is 80 × 60 mm = 48 cm²; the rounded edges move a little.
    EXPECT_NEAR(report.contact_area_cm2 + report.attachment_area_cm2, 48.0, 0.2 * 48.0);
    // The attachments: the lower face within 30 mm of its centre, π 30² = 28 cm².
    EXPECT_NEAR(report.attachment_area_cm2, M_PI * 9.0, 0.25 * M_PI * 9.0);
    EXPECT_DOUBLE_EQ(report.modulus, 5000.0 / 0.020);  // E over 20 mm
    EXPECT_EQ(report.unseen_vertices, 0u);
    EXPECT_TRUE(find_supports(*b.ct, m, o) == supports) << "deterministic";
  }
}

TEST(Supports, AFaceBeyondTheFieldOfViewIsFreeAndCountedUnseen) {
  const BlockOnMuscle b = block_on_muscle({1.0, 1.0, 1.0}, 0.0, true);
  const model::OrganModel m = model_of(*b.mask, {0.0, 0.0, 0.0});
  SupportReport report;
  const model::Supports supports = find_supports(*b.ct, m, {}, &report);
  std::size_t top = 0;
  for (std::size_t v = 0; v < m.surface_vertices.size(); ++v)
    if (z_mm(m, v) > 23.0 && std::abs(m.surface_vertices[v][0]) < 0.035 && std::abs(m.surface_vertices[v][1]) < 0.025) {
      ++top;
      EXPECT_EQ(supports.kind(v), model::Supports::Kind::kFree);
    }
  ASSERT_GT(top, 20u);
  EXPECT_GE(report.unseen_vertices, top);
  EXPECT_GT(report.contact_area_cm2 + report.attachment_area_cm2, 30.0) << "the lower face is still supported";
}

// The phantom (pipeline/phantom.h) lays its liver in visceral fat, clear of
// the abdominal wall, the kidney, the spine and the aorta (its surface lies
// within hypot(x / 158, y / 113) ≤ 0.83, the muscle from 0.93 on); only the
// portal vein (a capsule of radius 7 mm from (−20, 20, −110) to (−45, 10, −10)
// mm, 180 HU) enters it, at the fixed point. So its supports are where the
// vein meets it, attached there, and nowhere else.
double distance_to_vein_mm(const Eigen::Vector3d& p) {
  const Eigen::Vector3d a(-20.0, 20.0, -110.0), b(-45.0, 10.0, -10.0);
  const double t = std::clamp((p - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
  return (p - (a + t * (b - a))).norm() - 7.0;
}

TEST(Supports, ThePhantomsLiverRestsOnlyWhereTheGeneratorPutThePortalVein) {
  const Phantom phantom = make_phantom({});
  const model::OrganModel m = model_of(*phantom.liver_mask, phantom.fixed_point_mm);
  SupportReport report;
  const model::Supports supports = find_supports(*phantom.ct, m, {}, &report);
  double farthest_supported_mm = 0.0;
  for (std::size_t v = 0; v < m.surface_vertices.size(); ++v)
    if (supports.kind(v) != model::Supports::Kind::kFree) {
      const Eigen::Vector3d p =
          Eigen::Vector3d(m.surface_vertices[v][0], m.surface_vertices[v][1], m.surface_vertices[v][2]) * 1e3;
      farthest_supported_mm = std::max(farthest_supported_mm, distance_to_vein_mm(p));
      EXPECT_EQ(supports.kind(v), model::Supports::Kind::kAttachment) << "about the clamp at the vein's entry";
    }
  RecordProperty("supported", fmt::format("{} vertices, {:.1f} cm2, all within {:.1f} mm of the vein",
                                          report.contact_vertices + report.attachment_vertices,
                                          report.contact_area_cm2 + report.attachment_area_cm2, farthest_supported_mm));
  EXPECT_GT(report.attachment_vertices, 3u) << "the vein's entry";
  EXPECT_LT(farthest_supported_mm, 8.0) << "the band reaches 5 mm out, and the surface lies within a voxel";
  EXPECT_EQ(report.unseen_vertices, 0u);
}

TEST(Supports, OptionsOutOfRangeAreOneLineErrors) {
  const BlockOnMuscle b = block_on_muscle({2.0, 2.0, 2.0}, 0.0);
  const model::OrganModel m = model_of(*b.mask, {0.0, 0.0, 0.0});
  for (const auto& change : std::vector<std::function<void(SupportOptions&)>>{
           [](SupportOptions& o) { o.far_mm = o.near_mm; }, [](SupportOptions& o) { o.samples = 1; },
           [](SupportOptions& o) { o.yielding_depth_mm = 0.0; }, [](SupportOptions& o) { o.attachment_radius_mm = -1; },
           [](SupportOptions& o) { o.tissue_young_modulus = 1e20; }}) {
    SupportOptions o;
    change(o);
    try {
      find_supports(*b.ct, m, o);
      ADD_FAILURE() << "accepted";
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()).rfind("supports: ", 0), 0u) << e.what();
    }
  }
}

}  // namespace
}  // namespace organsim::pipeline

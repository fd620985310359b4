#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <fmt/format.h>

#include "organsim/geometry/model_measures.h"
#include "organsim/pipeline/segmentation.h"
#include "organsim/pipeline/surface.h"
#include "synthetic_volumes.h"

namespace organsim::pipeline {
namespace {

/// Knud Thomsen's formula for the ellipsoid's area (error ≤ 1.1 %, far below for
/// these axes); p = 1.6075.
double ellipsoid_area_mm2(const std::array<double, 3>& s) {
  const double p = 1.6075;
  const double ap = std::pow(s[0], p), bp = std::pow(s[1], p), cp = std::pow(s[2], p);
  return 4.0 * M_PI * std::pow((ap * bp + ap * cp + bp * cp) / 3.0, 1.0 / p);
}

TEST(Surface, EllipsoidVolumeAndAreaMatchTheAnalyticValues) {
  const testing::Ellipsoid e;
  const MaskImage::Pointer mask = testing::make_ellipsoid_mask(e);
  SurfaceOptions options;
  options.target_vertices = 4000;
  const geometry::SurfaceMesh mesh = extract_surface(*mask, options);
  EXPECT_LE(mesh.vertices.size(), 4400u);
  EXPECT_GE(mesh.vertices.size(), 3000u);
  const double volume = geometry::enclosed_volume(mesh.vertices, mesh.triangles) * 1e9;  // mm³
  const double area = geometry::surface_area(mesh.vertices, mesh.triangles) * 1e6;       // mm²
  EXPECT_NEAR(volume, e.volume_mm3(), 0.01 * e.volume_mm3());
  EXPECT_NEAR(area, ellipsoid_area_mm2(e.semi_axes_mm), 0.02 * ellipsoid_area_mm2(e.semi_axes_mm));
  RecordProperty("volume_error", std::to_string(volume / e.volume_mm3() - 1));
  RecordProperty("area_error", std::to_string(area / ellipsoid_area_mm2(e.semi_axes_mm) - 1));
  // In the patient frame: the centroid of the vertices is near the ellipsoid centre.
  double c[3] = {0, 0, 0};
  for (const model::Point3& p : mesh.vertices)
    for (int k = 0; k < 3; ++k) c[k] += p[k] / mesh.vertices.size();
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(c[k] * 1e3, e.centre_mm[k], 1.5);
}

TEST(Surface, EmptyMaskIsAnError) {
  const testing::Ellipsoid e;
  auto mask = testing::make_grid<MaskImage>(e, {4.0, 4.0, 4.0});
  EXPECT_THROW(extract_surface(*mask, SurfaceOptions{}), std::runtime_error);
}

/// Each directed edge once and its reverse once: closed, manifold, oriented.
void expect_closed_oriented_manifold(const geometry::SurfaceMesh& mesh) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> directed;
  for (const model::Triangle& t : mesh.triangles)
    for (int e = 0; e < 3; ++e) ++directed[{t[e], t[(e + 1) % 3]}];
  std::size_t bad = 0;
  for (const auto& [edge, count] : directed) {
    const auto opposite = directed.find({edge.second, edge.first});
    bad += count != 1 || opposite == directed.end() || opposite->second != 1;
  }
  EXPECT_EQ(bad, 0u) << "edges not shared by exactly two consistently oriented triangles";
  // One piece: every vertex reached from the first through the triangles.
  std::vector<std::uint32_t> parent(mesh.vertices.size());
  std::iota(parent.begin(), parent.end(), 0u);
  const auto find = [&](std::uint32_t v) {
    while (parent[v] != v) v = parent[v] = parent[parent[v]];
    return v;
  };
  for (const model::Triangle& t : mesh.triangles) {
    parent[find(t[1])] = find(t[0]);
    parent[find(t[2])] = find(t[0]);
  }
  std::size_t pieces = 0;
  for (std::uint32_t v = 0; v < parent.size(); ++v) pieces += find(v) == v;
  EXPECT_EQ(pieces, 1u);
  EXPECT_GT(geometry::enclosed_volume(mesh.vertices, mesh.triangles), 0.0);
}

TEST(Surface, AwkwardMaskGivesOneClosedManifoldAtEverySize) {
  const MaskImage::Pointer mask = testing::make_awkward_mask();
  for (const std::size_t target : {300u, 1000u, 3000u, 20000u}) {
    SCOPED_TRACE(target);
    SurfaceOptions options;
    options.target_vertices = target;
    expect_closed_oriented_manifold(extract_surface(*mask, options));
  }
}

/// Volume and shape against the analytic ellipsoid, with the mask's own
/// volume beside it (the mask is the best any surface of it can do).
struct VolumeCase {
  double about_z, about_x;        ///< the ellipsoid's orientation, rad
  std::array<double, 3> spacing;  ///< the grid's voxel size, mm
  long block_factor;
  std::size_t target_vertices;
  double tolerance;  ///< relative volume error allowed
};

void expect_volume_true(const VolumeCase& c) {
  SCOPED_TRACE(::testing::Message() << "rotation " << c.about_z << "," << c.about_x << " rad, spacing " << c.spacing[0]
                                    << "x" << c.spacing[1] << "x" << c.spacing[2] << " mm, block " << c.block_factor
                                    << ", " << c.target_vertices << " vertices");
  const testing::Ellipsoid e(c.about_z, c.about_x);
  const MaskImage::Pointer mask = testing::make_ellipsoid_mask(e, c.spacing);
  const double mask_mm3 = static_cast<double>(count_voxels(*mask)) * c.spacing[0] * c.spacing[1] * c.spacing[2];
  ASSERT_NEAR(mask_mm3, e.volume_mm3(), 0.002 * e.volume_mm3()) << "the test's mask itself";
  SurfaceOptions options;
  options.target_vertices = c.target_vertices;
  options.block_factor = c.block_factor;
  const geometry::SurfaceMesh mesh = extract_surface(*mask, options);
  expect_closed_oriented_manifold(mesh);
  const double volume = geometry::enclosed_volume(mesh.vertices, mesh.triangles) * 1e9;
  EXPECT_NEAR(volume, mask_mm3, c.tolerance * mask_mm3);
  EXPECT_NEAR(volume, e.volume_mm3(), c.tolerance * e.volume_mm3());
  ::testing::Test::RecordProperty(
      fmt::format("volume_error_z{}_x{}_s{}_{}_{}_block{}_{}", c.about_z, c.about_x, c.spacing[0], c.spacing[1],
                  c.spacing[2], c.block_factor, c.target_vertices),
      fmt::format("{:+.4f} % of the analytic volume", 100.0 * (volume / e.volume_mm3() - 1.0)));
  // The volume comes from the shape, not from an inflated or shrunk one: the
  // surface lies on the ellipsoid on average (the signed distance integrated
  // over the triangles, by the edge-midpoint rule, exact for the quadratic sag
  // of a chord) and its vertices lie near it everywhere. The vertices alone
  // sit outside on average: a volume-true polyhedron's chords cut inside a
  // convex surface, so its corners stand out by about the chords' sag.
  double area_sum = 0.0, weighted = 0.0;
  for (const model::Triangle& t : mesh.triangles) {
    const auto corner_mm = [&](int k) -> Eigen::Vector3d {
      const model::Point3& p = mesh.vertices[t[k]];
      return Eigen::Vector3d(p[0], p[1], p[2]) * 1e3;
    };
    const Eigen::Vector3d a = corner_mm(0), b = corner_mm(1), d = corner_mm(2);
    const double area = 0.5 * (b - a).cross(d - a).norm();
    for (const Eigen::Vector3d& m :
         {Eigen::Vector3d((a + b) / 2), Eigen::Vector3d((b + d) / 2), Eigen::Vector3d((d + a) / 2)})
      weighted += area / 3.0 * e.signed_distance_mm({m[0], m[1], m[2]});
    area_sum += area;
  }
  double squares = 0.0;
  for (const model::Point3& p : mesh.vertices) {
    const double d = e.signed_distance_mm({p[0] * 1e3, p[1] * 1e3, p[2] * 1e3});
    squares += d * d;
  }
  const double n = static_cast<double>(mesh.vertices.size());
  const double coarsest = c.block_factor * std::max({c.spacing[0], c.spacing[1], c.spacing[2]});
  EXPECT_LT(std::abs(weighted / area_sum), 0.05 * coarsest)
      << "mean signed distance of the surface to the ellipsoid, mm";
  EXPECT_LT(std::sqrt(squares / n), 0.25 * coarsest) << "RMS distance to the ellipsoid, mm";
}

TEST(Surface, VolumeTrueOnRotatedAnisotropicEllipsoids) {
  const std::array<std::array<double, 2>, 3> orientations{{{0.0, 0.0}, {0.4, 0.25}, {1.1, -0.7}}};
  const std::array<std::array<double, 3>, 3> spacings{{{1.0, 1.0, 1.0}, {0.9, 1.1, 1.6}, {0.7, 0.8, 2.5}}};
  for (const auto& r : orientations)
    for (const auto& s : spacings)
      for (const long block : {1L, 2L}) expect_volume_true({r[0], r[1], s, block, 3000, 0.003});
}

TEST(Surface, VolumeTrueAtEveryBlockFactorAndSize) {
  for (const long block : {1L, 2L, 3L, 4L})
    for (const std::size_t target : {std::size_t{3000}, std::size_t{10000}})
      expect_volume_true({0.4, 0.25, {0.9, 1.1, 1.6}, block, target, 0.003});
  // At 800 vertices decimation itself moves the surface by about 1 %.
  expect_volume_true({0.4, 0.25, {0.9, 1.1, 1.6}, 2, 800, 0.01});
}

TEST(Surface, ALongCylinderStaysWithinItsCapsAndSide) {
  // A straight cylinder (radius 25 mm, x from 0 to 150 mm, 1 mm voxels),
  // decimated to 4,000 vertices: its surface's long strips along the side are
  // where a low-pass filter after decimation slid vertices past the caps, into
  // zero-volume fins 9 mm long (the baked surface ran from x = −9 to 159 mm).
  const double radius = 25.0, length = 150.0;
  auto mask = testing::blank_mask({170, 70, 70}, 1.0, {-9.5, -34.5, -34.5});  // voxel centres off the caps and side
  itk::ImageRegionIteratorWithIndex<MaskImage> it(mask, mask->GetLargestPossibleRegion());
  for (; !it.IsAtEnd(); ++it) {
    MaskImage::PointType p;
    mask->TransformIndexToPhysicalPoint(it.GetIndex(), p);
    it.Set(p[0] > 0.0 && p[0] < length && std::hypot(p[1], p[2]) < radius ? 1 : 0);
  }
  SurfaceOptions options;
  options.target_vertices = 4000;
  const geometry::SurfaceMesh mesh = extract_surface(*mask, options);
  expect_closed_oriented_manifold(mesh);
  double farthest_mm = 0.0, lowest_x = 1e9, highest_x = -1e9;
  for (const model::Point3& v : mesh.vertices) {
    const double x = v[0] * 1e3, r = std::hypot(v[1], v[2]) * 1e3;
    // Distance to the capped cylinder's surface (inside: to the nearest face;
    // outside: to the solid).
    const double out_x = std::max(-x, x - length), out_r = r - radius;
    const double distance = out_x > 0.0 || out_r > 0.0 ? std::hypot(std::max(out_x, 0.0), std::max(out_r, 0.0))
                                                       : std::min({-out_x, -out_r});
    farthest_mm = std::max(farthest_mm, distance);
    lowest_x = std::min(lowest_x, x), highest_x = std::max(highest_x, x);
  }
  EXPECT_GT(lowest_x, -1.0);
  EXPECT_LT(highest_x, length + 1.0);
  // The smoothing rounds the caps' rims by a few voxels; nothing else is off.
  EXPECT_LT(farthest_mm, 3.0);
  RecordProperty("farthest_from_cylinder_mm", std::to_string(farthest_mm));
}

TEST(Surface, BlockFactorOutsideOneToFourIsAnError) {
  const testing::Ellipsoid e;
  const MaskImage::Pointer mask = testing::make_ellipsoid_mask(e, {2.0, 2.0, 2.0});
  SurfaceOptions options;
  options.block_factor = 5;
  EXPECT_THROW(extract_surface(*mask, options), std::invalid_argument);
}

}  // namespace
}  // namespace organsim::pipeline

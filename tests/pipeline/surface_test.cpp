#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <numeric>

#include "organsim/geometry/model_measures.h"
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
  const double area = geometry::surface_area(mesh.vertices, mesh.triangles) * 1e6; // mm²
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

}  // namespace
}  // namespace organsim::pipeline

#include <gtest/gtest.h>

#include <string>

#include "organsim/pipeline/surface.h"
#include "organsim/pipeline/tetrahedra.h"
#include "synthetic_volumes.h"

namespace organsim::pipeline {
namespace {

geometry::SurfaceMesh ellipsoid_surface() {
  const testing::Ellipsoid e;
  SurfaceOptions options;
  options.target_vertices = 4000;
  return extract_surface(*testing::make_ellipsoid_mask(e), options);
}

TEST(Tetrahedra, EllipsoidVolumeMatchesTheAnalyticValueAndTheQualityIsBounded) {
  const testing::Ellipsoid e;
  const geometry::SurfaceMesh surface = ellipsoid_surface();
  TetrahedraOptions options;
  options.tet_size_mm = 8.0;
  const geometry::TetrahedralMesh mesh = make_tetrahedra(surface, options);
  const TetrahedralQuality q = measure_quality(mesh);
  ASSERT_GT(q.tetrahedra, 1000u);
  const double volume_mm3 = q.total_volume_m3 * 1e9;
  EXPECT_NEAR(volume_mm3, e.volume_mm3(), 0.01 * e.volume_mm3());
  EXPECT_GT(q.min_volume_m3, 0.0);  // every tetrahedron positively oriented
  // Sliver removal keeps every dihedral angle away from 0° and 180°.
  EXPECT_GT(q.min_dihedral_deg, 5.0);
  EXPECT_LT(q.max_dihedral_deg, 170.0);
  EXPECT_LT(q.mean_radius_edge_ratio, 1.2);
  for (const model::Tetrahedron& t : mesh.tetrahedra)
    for (std::uint32_t v : t) ASSERT_LT(v, mesh.vertices.size());
  RecordProperty("tetrahedra", std::to_string(q.tetrahedra));
  RecordProperty("volume_error", std::to_string(volume_mm3 / e.volume_mm3() - 1));
  RecordProperty("min_dihedral_deg", std::to_string(q.min_dihedral_deg));
  RecordProperty("max_radius_edge_ratio", std::to_string(q.max_radius_edge_ratio));
}

TEST(Tetrahedra, SmallerTetSizeGivesMoreTetrahedra) {
  const geometry::SurfaceMesh surface = ellipsoid_surface();
  TetrahedraOptions coarse, fine;
  coarse.tet_size_mm = 12.0;
  fine.tet_size_mm = 6.0;
  coarse.optimize = fine.optimize = false;
  const std::size_t n_coarse = make_tetrahedra(surface, coarse).tetrahedra.size();
  const std::size_t n_fine = make_tetrahedra(surface, fine).tetrahedra.size();
  // Halving the size multiplies the count by about 8 in the interior.
  EXPECT_GT(static_cast<double>(n_fine), 3.0 * static_cast<double>(n_coarse));
}

TEST(Tetrahedra, IsDeterministic) {
  const geometry::SurfaceMesh surface = ellipsoid_surface();
  TetrahedraOptions options;
  options.tet_size_mm = 10.0;
  const geometry::TetrahedralMesh a = make_tetrahedra(surface, options), b = make_tetrahedra(surface, options);
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.tetrahedra, b.tetrahedra);
}

TEST(Tetrahedra, QualityOfARegularTetrahedron) {
  geometry::TetrahedralMesh mesh;
  mesh.vertices = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  mesh.tetrahedra = {{0, 1, 2, 3}};
  const TetrahedralQuality q = measure_quality(mesh);
  const double dihedral = std::acos(1.0 / 3.0) * 180.0 / M_PI;  // 70.53°
  EXPECT_NEAR(q.min_dihedral_deg, dihedral, 1e-9);
  EXPECT_NEAR(q.max_dihedral_deg, dihedral, 1e-9);
  EXPECT_NEAR(q.max_radius_edge_ratio, std::sqrt(6.0) / 4.0, 1e-12);
  EXPECT_NEAR(std::abs(q.total_volume_m3), 8.0 / 3.0, 1e-12);
}

TEST(Tetrahedra, UnusableOptionsAreErrors) {
  const geometry::SurfaceMesh surface = ellipsoid_surface();
  TetrahedraOptions options;
  options.tet_size_mm = 0.0;
  EXPECT_THROW(make_tetrahedra(surface, options), std::runtime_error);
  options = {};
  options.radius_edge_ratio = 1.0;
  EXPECT_THROW(make_tetrahedra(surface, options), std::runtime_error);
}

}  // namespace
}  // namespace organsim::pipeline

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <limits>
#include <map>
#include <string>

#include <Eigen/Geometry>

#include "organsim/geometry/model_measures.h"
#include "organsim/tetrahedra/connected_part.h"
#include "organsim/pipeline/surface.h"
#include "organsim/tetrahedra/sliver_removal.h"
#include "organsim/tetrahedra/tetrahedra.h"
#include "synthetic_volumes.h"

namespace organsim::pipeline {
namespace {

geometry::SurfaceMesh ellipsoid_surface() {
  const testing::Ellipsoid e;
  SurfaceOptions options;
  options.target_vertices = 4000;
  return extract_surface(*testing::make_ellipsoid_mask(e), options);
}

// Boundary facets are chords of the surface; the boundary vertices' offset
// gives the tetrahedra the surface's volume, and so the mask's and (to the
// mask's own rasterization error) the analytic one, in every orientation and
// spacing, without lowering the quality below the goals.
TEST(Tetrahedra, VolumeTrueOnRotatedAnisotropicEllipsoids) {
  const std::array<std::array<double, 2>, 3> orientations{{{0.0, 0.0}, {0.4, 0.25}, {1.1, -0.7}}};
  const std::array<std::array<double, 3>, 3> spacings{{{1.0, 1.0, 1.0}, {0.9, 1.1, 1.6}, {0.7, 0.8, 2.5}}};
  for (const auto& r : orientations)
    for (const auto& spacing : spacings) {
      SCOPED_TRACE(::testing::Message() << "rotation " << r[0] << "," << r[1] << " rad, spacing " << spacing[0] << "x"
                                        << spacing[1] << "x" << spacing[2] << " mm");
      const testing::Ellipsoid e(r[0], r[1]);
      const geometry::SurfaceMesh surface =
          extract_surface(*testing::make_ellipsoid_mask(e, spacing), SurfaceOptions{});
      const TetrahedralQuality q = measure_quality(make_tetrahedra(surface, TetrahedraOptions{}));
      const double surface_mm3 = geometry::enclosed_volume(surface.vertices, surface.triangles) * 1e9;
      EXPECT_NEAR(q.total_volume_m3 * 1e9, surface_mm3, 1e-6 * surface_mm3);
      EXPECT_NEAR(q.total_volume_m3 * 1e9, e.volume_mm3(), 0.003 * e.volume_mm3());
      EXPECT_GE(q.min_dihedral_deg, kMinDihedralGoalDeg);
      EXPECT_LE(q.max_radius_edge_ratio, kMaxRadiusEdgeGoal);
    }
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

// Mean edge length (mm) of the tetrahedra whose centroid lies within
// [near, far) mm of `centre`.
double mean_edge_mm(const geometry::TetrahedralMesh& mesh, const Eigen::Vector3d& centre, double near, double far) {
  double sum = 0.0;
  int edges = 0;
  for (const model::Tetrahedron& t : mesh.tetrahedra) {
    Eigen::Vector3d p[4], centroid = Eigen::Vector3d::Zero();
    for (int i = 0; i < 4; ++i) {
      p[i] = Eigen::Vector3d(mesh.vertices[t[i]][0], mesh.vertices[t[i]][1], mesh.vertices[t[i]][2]) * 1e3;
      centroid += 0.25 * p[i];
    }
    const double distance = (centroid - centre).norm();
    if (distance < near || distance >= far) continue;
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j, ++edges) sum += (p[i] - p[j]).norm();
  }
  return edges > 0 ? sum / edges : 0.0;
}

// Where a tool presses, finer cells: about the refinement's size within its
// radius, the mesh unchanged far from it, the volume and the quality goals kept.
TEST(Tetrahedra, RefinementMakesTheCellsFineAroundAPointOnly) {
  const geometry::SurfaceMesh surface = ellipsoid_surface();
  const auto at = std::max_element(surface.vertices.begin(), surface.vertices.end(),
                                   [](const model::Point3& a, const model::Point3& b) { return a[0] < b[0]; });
  const Eigen::Vector3d centre_mm = Eigen::Vector3d((*at)[0], (*at)[1], (*at)[2]) * 1e3;
  TetrahedraOptions uniform, refined;
  uniform.tet_size_mm = refined.tet_size_mm = 8.0;
  refined.refinements.push_back({*at, 6.0, 2.0});
  const geometry::TetrahedralMesh coarse = make_tetrahedra(surface, uniform), fine = make_tetrahedra(surface, refined);
  const double coarse_near = mean_edge_mm(coarse, centre_mm, 0.0, 6.0),
               fine_near = mean_edge_mm(fine, centre_mm, 0.0, 6.0);
  RecordProperty("mean_edge_near_mm", std::to_string(fine_near));
  EXPECT_LT(fine_near, 0.4 * coarse_near);
  EXPECT_LT(fine_near, 2.0 * 2.0) << "Mesh_3's size bounds circumradii: edges up to about 1.6 times";
  const double far = 8.0 / kRefinementGrading + 6.0 + 10.0;  // beyond where the cells grow back to 8 mm
  EXPECT_NEAR(mean_edge_mm(fine, centre_mm, far, 1e9), mean_edge_mm(coarse, centre_mm, far, 1e9),
              0.1 * mean_edge_mm(coarse, centre_mm, far, 1e9));
  const TetrahedralQuality q = measure_quality(fine);
  EXPECT_GT(q.tetrahedra, measure_quality(coarse).tetrahedra);
  EXPECT_NEAR(q.total_volume_m3, geometry::enclosed_volume(surface.vertices, surface.triangles),
              1e-6 * q.total_volume_m3);
  EXPECT_GE(q.min_dihedral_deg, kMinDihedralGoalDeg);
  EXPECT_LE(q.max_radius_edge_ratio, kMaxRadiusEdgeGoal);
  const geometry::TetrahedralMesh again = make_tetrahedra(surface, refined);
  EXPECT_EQ(again.vertices, fine.vertices);
  EXPECT_EQ(again.tetrahedra, fine.tetrahedra);

  TetrahedraOptions bad = refined;
  bad.refinements[0].size_mm = 0.0;
  EXPECT_THROW(make_tetrahedra(surface, bad), std::runtime_error);
  bad.refinements[0].size_mm = 2.0;
  bad.refinements[0].centre[1] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(make_tetrahedra(surface, bad), std::runtime_error);
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

// Every tetrahedron positive, every face in one or two tetrahedra, every
// boundary edge in exactly two boundary faces: a closed 2-manifold boundary.
void expect_valid_with_manifold_boundary(const geometry::TetrahedralMesh& mesh) {
  std::map<std::array<std::uint32_t, 3>, int> faces;
  for (const model::Tetrahedron& t : mesh.tetrahedra) {
    const auto& v = mesh.vertices;
    auto e = [&](int i) { return Eigen::Vector3d(v[t[i]][0], v[t[i]][1], v[t[i]][2]); };
    ASSERT_GT((e(1) - e(0)).cross(e(2) - e(0)).dot(e(3) - e(0)), 0.0);
    for (const auto& f :
         {std::array<std::uint32_t, 3>{t[1], t[2], t[3]}, {t[0], t[2], t[3]}, {t[0], t[1], t[3]}, {t[0], t[1], t[2]}}) {
      auto key = f;
      std::sort(key.begin(), key.end());
      ++faces[key];
    }
  }
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> boundary_edges;
  for (const auto& [f, uses] : faces) {
    ASSERT_LE(uses, 2);
    if (uses == 1)
      for (const auto& [a, b] : {std::pair{f[0], f[1]}, {f[1], f[2]}, {f[0], f[2]}}) ++boundary_edges[{a, b}];
  }
  for (const auto& [edge, uses] : boundary_edges) ASSERT_EQ(uses, 2);
}

TEST(SliverRemoval, PeelsBoundarySliversAndMovesInteriorVerticesKeepingTheBoundaryManifold) {
  // Mesh_3 without its own optimization leaves slivers of both kinds.
  TetrahedraOptions raw;
  raw.optimize = false;
  geometry::TetrahedralMesh mesh = make_tetrahedra(ellipsoid_surface(), raw);
  const double volume_before = measure_quality(mesh).total_volume_m3;
  const SliverRemovalReport r = remove_slivers(mesh);
  EXPECT_LT(r.min_dihedral_before_deg, 5.0);
  EXPECT_GT(r.slivers_before, 10u);
  EXPECT_GT(r.peeled, 0u);
  EXPECT_GT(r.flips + r.moves, 0u);
  EXPECT_LT(r.slivers_after, r.slivers_before / 4);
  EXPECT_GT(r.min_dihedral_after_deg, r.min_dihedral_before_deg + 3.0);
  EXPECT_NEAR(measure_quality(mesh).min_dihedral_deg, r.min_dihedral_after_deg, 1e-9);
  EXPECT_LT(std::abs(measure_quality(mesh).total_volume_m3 / volume_before - 1.0), 0.005);
  expect_valid_with_manifold_boundary(mesh);
  RecordProperty("min_dihedral_after_deg", std::to_string(r.min_dihedral_after_deg));
}

TEST(SliverRemoval, AnInteriorVertexPressedOntoAFaceIsMovedBack) {
  // A tetrahedron cut into four by an inner vertex that sits 1 % of the height above face ABC.
  geometry::TetrahedralMesh mesh;
  mesh.vertices = {{1, 1, 1}, {1, -1, -1}, {-1, 1, -1}, {-1, -1, 1}};
  const Eigen::Vector3d face_centre =
      (Eigen::Vector3d(1, 1, 1) + Eigen::Vector3d(1, -1, -1) + Eigen::Vector3d(-1, 1, -1)) / 3;
  const Eigen::Vector3d inner = face_centre + 0.01 * (Eigen::Vector3d(-1, -1, 1) - face_centre);
  mesh.vertices.push_back({inner[0], inner[1], inner[2]});
  for (const model::Tetrahedron& t : {model::Tetrahedron{0, 1, 2, 4}, {0, 1, 4, 3}, {0, 4, 2, 3}, {4, 1, 2, 3}}) {
    model::Tetrahedron oriented = t;
    const auto& v = mesh.vertices;
    auto e = [&](int i) { return Eigen::Vector3d(v[oriented[i]][0], v[oriented[i]][1], v[oriented[i]][2]); };
    if ((e(1) - e(0)).cross(e(2) - e(0)).dot(e(3) - e(0)) < 0) std::swap(oriented[2], oriented[3]);
    mesh.tetrahedra.push_back(oriented);
  }
  const SliverRemovalReport r = remove_slivers(mesh);
  EXPECT_LT(r.min_dihedral_before_deg, 3.0);
  EXPECT_EQ(r.peeled, 0u);
  EXPECT_GE(r.min_dihedral_after_deg, 15.0);
  EXPECT_EQ(r.slivers_after, 0u);
  // The corners are boundary vertices at sharp corners: they stay.
  EXPECT_EQ(mesh.vertices[0], (model::Point3{1, 1, 1}));
  EXPECT_EQ(mesh.vertices[3], (model::Point3{-1, -1, 1}));
  expect_valid_with_manifold_boundary(mesh);
}

// The boundary's triangles (sorted vertex triples), each with its outward side.
std::map<std::array<std::uint32_t, 3>, int> boundary_faces(const geometry::TetrahedralMesh& mesh) {
  std::map<std::array<std::uint32_t, 3>, int> faces;
  for (const model::Tetrahedron& t : mesh.tetrahedra)
    for (const auto& f :
         {std::array<std::uint32_t, 3>{t[1], t[2], t[3]}, {t[0], t[2], t[3]}, {t[0], t[1], t[3]}, {t[0], t[1], t[2]}}) {
      auto key = f;
      std::sort(key.begin(), key.end());
      ++faces[key];
    }
  for (auto it = faces.begin(); it != faces.end();) it = it->second == 2 ? faces.erase(it) : std::next(it);
  return faces;
}

// Two flat tetrahedra on either side of one triangle, every vertex a corner
// of the boundary: moving a vertex would change the boundary, but the same
// five vertices connected as three tetrahedra around the new edge de (a 2-3
// flip) are well shaped.
TEST(SliverRemoval, PinnedSliversAreFlippedNotMoved) {
  geometry::TetrahedralMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {-0.2, 0.9, 0}, {0.2, 0.2, 0.1}, {-0.1, 0.2, -0.3}};  // a, b, c, d, e
  for (const model::Tetrahedron& t : {model::Tetrahedron{0, 1, 2, 3}, {0, 2, 1, 4}}) {
    model::Tetrahedron oriented = t;
    const auto& v = mesh.vertices;
    auto e = [&](int i) { return Eigen::Vector3d(v[oriented[i]][0], v[oriented[i]][1], v[oriented[i]][2]); };
    ASSERT_GT((e(1) - e(0)).cross(e(2) - e(0)).dot(e(3) - e(0)), 0.0);
    mesh.tetrahedra.push_back(oriented);
  }
  const geometry::TetrahedralMesh before = mesh;
  const SliverRemovalReport r = remove_slivers(mesh, {15.0, 20});
  EXPECT_LT(r.min_dihedral_before_deg, 10.0);
  EXPECT_EQ(r.peeled, 0u);
  EXPECT_EQ(r.flips, 1u);
  EXPECT_EQ(mesh.tetrahedra.size(), 3u);
  EXPECT_GT(r.min_dihedral_after_deg, 15.0);
  EXPECT_EQ(mesh.vertices, before.vertices);
  EXPECT_EQ(boundary_faces(mesh), boundary_faces(before));
  EXPECT_NEAR(measure_quality(mesh).total_volume_m3, measure_quality(before).total_volume_m3, 1e-12);
  expect_valid_with_manifold_boundary(mesh);
  RecordProperty("min_dihedral_before_deg", std::to_string(r.min_dihedral_before_deg));
  RecordProperty("min_dihedral_after_deg", std::to_string(r.min_dihedral_after_deg));
}

// Two tetrahedra sharing a face, one touching them at a vertex only and one
// apart: only the first two stay, with the vertices they use, renumbered.
TEST(ConnectedPart, KeepsTheLargestFaceConnectedPart) {
  geometry::TetrahedralMesh mesh;
  mesh.vertices = {{9, 9, 9}, {0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}, {2, 2, 2},
                   {3, 2, 2}, {2, 3, 2}, {5, 5, 5}, {6, 5, 5}, {5, 6, 5}, {5, 5, 6}};
  mesh.tetrahedra = {{9, 10, 11, 12}, {1, 2, 3, 4}, {2, 3, 4, 5}, {5, 6, 7, 8}};
  const ConnectedPartReport r = keep_largest_connected_part(mesh);
  EXPECT_EQ(r.tetrahedra_dropped, 2u);
  EXPECT_EQ(r.vertices_dropped, 8u);
  ASSERT_EQ(mesh.vertices.size(), 5u);
  EXPECT_EQ(mesh.vertices.front(), (model::Point3{0, 0, 0}));
  EXPECT_EQ(mesh.vertices.back(), (model::Point3{1, 1, 1}));
  EXPECT_EQ(mesh.tetrahedra, (std::vector<model::Tetrahedron>{{0, 1, 2, 3}, {1, 2, 3, 4}}));
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

namespace organsim::pipeline {
namespace {

TEST(Tetrahedra, QualityWarningsNameAMissNoMatterHowSmall) {
  TetrahedralQuality q;
  q.tetrahedra = 100;
  q.min_dihedral_deg = kMinDihedralGoalDeg;
  q.max_radius_edge_ratio = kMaxRadiusEdgeGoal;
  EXPECT_TRUE(tetrahedra_quality_warnings(q).empty());
  q.min_dihedral_deg = kMinDihedralGoalDeg - 0.05;  // 11.95°: shown as such, not rounded up to the goal
  q.max_radius_edge_ratio = 3.68;
  const std::vector<std::string> warnings = tetrahedra_quality_warnings(q);
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_NE(warnings[0].find("11.95°"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[1].find("3.68"), std::string::npos) << warnings[1];
}

}  // namespace
}  // namespace organsim::pipeline

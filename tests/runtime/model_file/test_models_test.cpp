// The test helpers' models are themselves checked against analytic values,
// since other tests rely on them.
#include <gtest/gtest.h>

#include <cmath>

#include "organsim/geometry/model_measures.h"
#include "test_models.h"

namespace organsim {
namespace {

constexpr double kPi = 3.14159265358979323846;

TEST(CylinderModel, GeometryMatchesThePolygonalCylinder) {
  testing::CylinderSpec spec;
  const model::OrganModel m = testing::make_cylinder_model(spec);
  ASSERT_EQ(model::validate_organ_model(m), "");
  const geometry::ModelMeasures measures = geometry::measure_model(m);
  const double polygon_area = 0.5 * spec.segments * spec.radius * spec.radius * std::sin(2 * kPi / spec.segments);
  const double polygon_perimeter = 2.0 * spec.segments * spec.radius * std::sin(kPi / spec.segments);
  EXPECT_NEAR(measures.tetrahedra_volume, polygon_area * spec.length, 1e-12);
  EXPECT_GT(measures.min_tetrahedron_volume, 0.0);
  EXPECT_NEAR(measures.surface_enclosed_volume, polygon_area * spec.length, 1e-12);
  EXPECT_NEAR(measures.surface_area, 2 * polygon_area + polygon_perimeter * spec.length, 1e-12);
  EXPECT_NEAR(measures.bounds_max.x() - measures.bounds_min.x(), spec.length, 1e-15);
}

TEST(CylinderModel, AxialBeamSectionsAreCircles) {
  testing::CylinderSpec spec;
  const model::OrganModel m = testing::make_cylinder_model(spec);
  // The far cap centre is the last surface vertex: its beam runs along the axis.
  const std::size_t tip = m.surface_vertices.size() - 1;
  const double r = spec.radius;
  for (std::uint32_t s = 0; s < spec.stations; ++s) {
    const model::BeamSection& section = m.beams.at(tip, s);
    EXPECT_NEAR(section.area, kPi * r * r, 1e-4 * kPi * r * r);
    EXPECT_NEAR(section.i_yy, kPi * std::pow(r, 4) / 4, 1e-4 * kPi * std::pow(r, 4) / 4);
    EXPECT_NEAR(section.i_zz, kPi * std::pow(r, 4) / 4, 1e-4 * kPi * std::pow(r, 4) / 4);
    EXPECT_NEAR(section.i_yz, 0.0, 1e-9 * std::pow(r, 4));
    EXPECT_NEAR(section.torsion_j, kPi * std::pow(r, 4) / 2, 1e-4 * kPi * std::pow(r, 4) / 2);
    EXPECT_NEAR(section.centroid_y, 0.0, 1e-9 * r);
    EXPECT_NEAR(section.centroid_z, 0.0, 1e-9 * r);
  }
}

TEST(CylinderModel, ObliqueSectionsAreClippedEllipses) {
  // A beam to a far-rim vertex is tilted by θ from the axis; its mid-length
  // section lies away from both caps and is an ellipse with semi-axes r/cos θ and r.
  testing::CylinderSpec spec;
  spec.stations = 21;
  const model::OrganModel m = testing::make_cylinder_model(spec);
  const std::size_t rim = spec.rings * spec.segments;  // first vertex of the far ring
  const model::Point3& v = m.surface_vertices[rim];
  const double cos_theta = v[0] / std::hypot(v[0], v[1], v[2]);
  const double r = spec.radius, a = r / cos_theta;
  const model::BeamSection& mid = m.beams.at(rim, 10);
  EXPECT_NEAR(mid.area, kPi * a * r, 1e-4 * kPi * a * r);
  EXPECT_NEAR(mid.i_yy + mid.i_zz, kPi * a * r * (a * a + r * r) / 4, 1e-4 * kPi * a * r * (a * a + r * r) / 4);
  EXPECT_NEAR(mid.torsion_j, kPi * std::pow(a * r, 3) / (a * a + r * r),
              1e-3 * kPi * std::pow(a * r, 3) / (a * a + r * r));
  // The beam passes through the axis only at the fixed point, so the centroid is offset.
  EXPECT_GT(std::hypot(mid.centroid_y, mid.centroid_z), 0.1 * r);
}

TEST(SphereModel, HasRequestedSizeAndIsClosed) {
  const model::OrganModel m = testing::make_sphere_model(100000, 20);
  ASSERT_EQ(model::validate_organ_model(m), "");
  EXPECT_NEAR(static_cast<double>(m.surface_vertices.size()), 100000.0, 1000.0);
  const geometry::ModelMeasures measures = geometry::measure_model(m);
  EXPECT_NEAR(measures.surface_enclosed_volume, measures.tetrahedra_volume, 1e-12);
  EXPECT_NEAR(measures.tetrahedra_volume, 4.0 / 3.0 * kPi * std::pow(0.08, 3), 0.01 * std::pow(0.08, 3));
}

}  // namespace
}  // namespace organsim

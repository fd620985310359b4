// The FEM reference's contact law at a site (organ/site_law.h) and the fast
// models that give it: the punch's closed forms, the law built from the
// model's compliances (renumbered with the surface), its depth curve, and the
// multi-beam and mass-spring models' contact forces.
#include <gtest/gtest.h>

#include <cmath>

#include "organsim/geometry/model_measures.h"
#include "organsim/organ/organ.h"
#include "organsim/organ/site_law.h"
#include "organsim/realtime/model_registry.h"
#include "test_models.h"

namespace organsim::organ {
namespace {

constexpr double kYoung = 5000.0, kPoisson = 0.49, kRadius = 0.0025;

// Boussinesq's rigid flat punch, F = 2 a E* d (E* = E / (1 − ν²)), and
// Mindlin's tangential stiffness 8 G a / (2 − ν).
TEST(SiteLaw, PunchAndDiskComplianceAreTheClosedForms) {
  const Eigen::Vector3d n = Eigen::Vector3d(1, 2, 2) / 3.0, t = Eigen::Vector3d(2, -2, 1) / 3.0;
  const double e_star = kYoung / (1 - kPoisson * kPoisson), shear = kYoung / (2 * (1 + kPoisson));
  const Eigen::Matrix3d punch = punch_compliance(kYoung, kPoisson, kRadius, n);
  EXPECT_NEAR(1.0 / n.dot(punch * n), 2 * kRadius * e_star, 1e-9 * kRadius * e_star);
  EXPECT_NEAR(1.0 / t.dot(punch * t), 8 * shear * kRadius / (2 - kPoisson), 1e-9 * shear * kRadius);
  EXPECT_NEAR(t.dot(punch * n), 0.0, 1e-12);
  // A uniform pressure over a disk gives the disk a mean deflection 16/(3π)
  // (1 − ν²) p b / E (Johnson, Contact Mechanics, §3.2): 8 % above the punch's.
  const Eigen::Matrix3d disk = disk_compliance(kYoung, kPoisson, kRadius, n);
  const double pressure_per_newton = 1.0 / (M_PI * kRadius * kRadius);
  EXPECT_NEAR(n.dot(disk * n), 16.0 / (3 * M_PI) * pressure_per_newton * kRadius / e_star, 1e-12);
  EXPECT_NEAR(n.dot(disk * n) / n.dot(punch * n), 32.0 / (3 * M_PI * M_PI), 1e-9);
}

model::OrganModel cylinder_with_sites() {
  model::OrganModel m = testing::make_cylinder_model({});
  m.sites.young_modulus = kYoung;
  m.sites.poisson_ratio = kPoisson;
  // The organ gives more the farther from the clamp at x = 0: 0.1 m/N + x · 1 (m/N)/m along z.
  for (const model::Point3& p : m.surface_vertices) m.sites.compliance.push_back({0.05, 0.05, 0.1 + p[0], 0, 0, 0});
  return m;
}

TEST(SiteLaw, TheLawIsTheOrgansComplianceInSeriesWithThePunchFollowingTheVertices) {
  const Organ organ(cylinder_with_sites());
  ASSERT_NE(organ.file_vertex_index()[0], 0u);  // the surface was renumbered
  // A point on top of the cylinder (outward normal +z), 0.1 m from the clamp.
  const geometry::SurfacePoint at = organ.surface_tree().closest_point({0.1, 0.0, 0.05});
  SiteLaw law;
  ASSERT_TRUE(law.set(organ, at, kRadius));
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // interpolated from the vertices' rest normals
  for (int k = 0; k < 3; ++k)
    normal += at.barycentric[k] *
              Eigen::Vector3d(organ.rest_normals()[organ.model().surface_triangles[at.triangle][k]].data());
  normal.normalize();
  EXPECT_GT(normal.dot(geometry::triangle_normal(organ.model(), at.triangle)), 0.99);
  Eigen::Matrix3d compliance = Eigen::Vector3d(0.05, 0.05, 0.1 + at.position[0]).asDiagonal();
  compliance += punch_compliance(kYoung, kPoisson, kRadius, normal);
  const Eigen::Matrix3d expected = compliance.inverse();
  EXPECT_LT((law.stiffness() - expected).norm(), 1e-9 * expected.norm());
  const Eigen::Vector3d d(0.001, -0.002, -0.004);
  EXPECT_LT((law.force(d) + expected * d).norm(), 1e-12);
  EXPECT_LT((law.tangent(d) - expected).norm(), 1e-9 * expected.norm());

  SiteLaw point;
  EXPECT_FALSE(point.set(organ, at, 0.0));  // a point has no finite indentation stiffness
  const Organ without(testing::make_cylinder_model({}));
  EXPECT_FALSE(point.set(without, without.surface_tree().closest_point({0.1, 0.0, 0.05}), kRadius));
}

TEST(SiteLaw, TheDepthCurveScalesTheForceAndItsTangentFollows) {
  model::OrganModel m = cylinder_with_sites();
  m.sites.depth_curve = {{{0.0, 1.0}}, {{0.004, 1.5}}, {{0.010, 3.0}}};
  m.sites.curve_tip_radius = kRadius;
  const Organ organ(std::move(m));
  const geometry::SurfacePoint at = organ.surface_tree().closest_point({0.1, 0.0, 0.05});
  SiteLaw law;
  ASSERT_TRUE(law.set(organ, at, kRadius));
  EXPECT_DOUBLE_EQ(law.depth_factor(0.0), 1.0);
  EXPECT_DOUBLE_EQ(law.depth_factor(0.002), 1.25);
  EXPECT_DOUBLE_EQ(law.depth_factor(0.007), 2.25);
  EXPECT_DOUBLE_EQ(law.depth_factor(0.05), 3.0);  // held beyond the last depth
  const Eigen::Vector3d normal = geometry::triangle_normal(organ.model(), at.triangle);
  const Eigen::Vector3d d = -0.006 * normal;
  EXPECT_LT((law.force(d) + 2.0 * law.stiffness() * d).norm(), 1e-12);
  // The tangent is the symmetric part of −∂F/∂d: central differences agree.
  const double h = 1e-7;
  Eigen::Matrix3d numeric;
  for (int k = 0; k < 3; ++k)
    numeric.col(k) = -(law.force(d + h * Eigen::Vector3d::Unit(k)) - law.force(d - h * Eigen::Vector3d::Unit(k))) / (2 * h);
  EXPECT_LT((law.tangent(d) - 0.5 * (numeric + numeric.transpose())).norm(), 1e-6 * numeric.norm());
  // A tip twice the size reads the curve at half the depth.
  SiteLaw larger;
  ASSERT_TRUE(larger.set(organ, at, 2 * kRadius));
  EXPECT_DOUBLE_EQ(larger.depth_factor(0.004), 1.25);
}

// The multi-beam and mass-spring models give a tool of finite size the site
// law's force and stiffness, and their own without site data or when told.
TEST(SiteLaw, TheFastModelsGiveTheLawsForce) {
  const Organ organ(cylinder_with_sites());
  const Eigen::Vector3d touch(0.1, 0.0, 0.03);  // on the cylinder's top (radius 0.03)
  geometry::ToolTip tip;
  tip.radius = kRadius;
  tip.axis = Eigen::Vector3d::UnitZ();
  SiteLaw law;
  ASSERT_TRUE(law.set(organ, organ.surface_tree().closest_point(touch), kRadius));
  const Eigen::Vector3d d(0.0, 0.0005, -0.003);
  for (const char* name : {"beam", "springs"})
    for (bool matched : {true, false}) {
      realtime::ModelOptions options;
      options.beams.match_sites = matched;
      options.springs.match_sites = matched;
      const auto model = realtime::make_deformation_model(name, organ, options, 1);
      realtime::ContactLinearization contact;
      ASSERT_TRUE(model->attach(0, touch, tip, contact)) << name;
      std::vector<model::Point3> positions(organ.vertex_count()), normals(organ.vertex_count());
      for (int frame = 0; frame < 3; ++frame)
        ASSERT_TRUE(model->step(1.0 / 60.0, &d, positions.data(), normals.data(), &contact)) << name;
      const Eigen::Vector3d force = contact.force - contact.stiffness * (d - contact.displacement);
      if (matched) {
        EXPECT_LT((force - law.force(d)).norm(), 1e-12) << name;
        EXPECT_LT((contact.stiffness - law.tangent(d)).norm(), 1e-9 * law.stiffness().norm()) << name;
      } else {
        EXPECT_GT((force - law.force(d)).norm(), 0.1 * law.force(d).norm()) << name << ": its own force";
      }
    }
}

}  // namespace
}  // namespace organsim::organ

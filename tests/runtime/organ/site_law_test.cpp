// The FEM reference's contact law at a site (organ/site_law.h) and the fast
// models that give it: the punch's closed forms, the sphere's Hertz law, the
// law built from the model's compliances (renumbered with the surface), its
// depth curve, on the supports, and the multi-beam and mass-spring models'
// contact forces.
#include <gtest/gtest.h>

#include <cmath>
#include <optional>
#include <vector>

#include "organsim/geometry/model_measures.h"
#include "organsim/organ/organ.h"
#include "organsim/organ/site_law.h"
#include "organsim/multibeam/multibeam.h"
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

/// A sphere of radius R on the half-space, N: Hertz, 4/3 E* √R δ^{3/2}, until
/// it is buried (δ = R), then a flat punch of radius R, 2 R E* per metre more.
double hertz_then_punch(double indentation) {
  const double e_star = kYoung / (1 - kPoisson * kPoisson);
  return indentation <= kRadius
             ? 4.0 / 3.0 * e_star * std::sqrt(kRadius) * std::pow(indentation, 1.5)
             : 4.0 / 3.0 * e_star * kRadius * kRadius + 2 * kRadius * e_star * (indentation - kRadius);
}

/// The tangent is the symmetric part of −∂F/∂d: central differences agree.
void expect_tangent_is_the_derivative(const SiteLaw& law, const Eigen::Vector3d& d) {
  const double h = 1e-8;
  Eigen::Matrix3d numeric;
  for (int k = 0; k < 3; ++k)
    numeric.col(k) =
        -(law.force(d + h * Eigen::Vector3d::Unit(k)) - law.force(d - h * Eigen::Vector3d::Unit(k))) / (2 * h);
  EXPECT_LT((law.tangent(d) - 0.5 * (numeric + numeric.transpose())).norm(), 1e-5 * numeric.norm()) << d.transpose();
}

TEST(SiteLaw, TheLawIsTheOrgansComplianceInSeriesWithTheTipFollowingTheVertices) {
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
  const Eigen::Matrix3d buried = compliance.inverse();
  EXPECT_LT((law.stiffness() - buried).norm(), 1e-9 * buried.norm());

  // A press 4 mm in and 2.2 mm across: the tip's indentation δ solves
  // d_n = δ + c_n F_tip(δ) (found here by bisection), and the force is the
  // organ's compliance in series with the tip's secant one at δ.
  const Eigen::Vector3d d(0.001, -0.002, -0.004);
  const double normal_depth = -normal.dot(d),
               organ_normal = normal.dot(compliance * normal) -
                              normal.dot(punch_compliance(kYoung, kPoisson, kRadius, normal) * normal);
  double low = 0.0, high = normal_depth;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (low + high);
    (mid + organ_normal * hertz_then_punch(mid) > normal_depth ? high : low) = mid;
  }
  const double indentation = 0.5 * (low + high), contact_radius = std::sqrt(kRadius * std::min(indentation, kRadius));
  EXPECT_NEAR(law.tip_indentation(normal_depth), indentation, 1e-12);
  const double shear = kYoung / (2 * (1 + kPoisson));
  Eigen::Matrix3d secant = Eigen::Vector3d(0.05, 0.05, 0.1 + at.position[0]).asDiagonal();
  secant += (2 - kPoisson) / (8 * shear * contact_radius) * Eigen::Matrix3d::Identity() +
            (indentation / hertz_then_punch(indentation) - (2 - kPoisson) / (8 * shear * contact_radius)) * normal *
                normal.transpose();
  EXPECT_LT((law.force(d) + secant.inverse() * d).norm(), 1e-9 * law.force(d).norm());
  EXPECT_LT(law.force(d).norm(), (buried * d).norm()) << "softer than the buried tip";
  expect_tangent_is_the_derivative(law, d);

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
  const Organ plain(cylinder_with_sites());
  SiteLaw without_curve;
  ASSERT_TRUE(without_curve.set(plain, plain.surface_tree().closest_point({0.1, 0.0, 0.05}), kRadius));
  EXPECT_LT((law.force(d) - 2.0 * without_curve.force(d)).norm(), 1e-12);
  expect_tangent_is_the_derivative(law, d);
  expect_tangent_is_the_derivative(law, -0.003 * normal + Eigen::Vector3d(0.002, 0.001, 0.0));  // a slope of the curve
  // A tip twice the size reads the curve at half the depth.
  SiteLaw larger;
  ASSERT_TRUE(larger.set(organ, at, 2 * kRadius));
  EXPECT_DOUBLE_EQ(larger.depth_factor(0.004), 1.25);
}

// A patch held in the jaws: without a pull curve the bonded punch in series
// with the organ, F = F(d_g) − (C_organ + C_punch)⁻¹ (d − d_g); with one, the
// punch's compliance scaled by s(u) at the distance drawn since closing (read
// at u R_fit / R), and the tangent is the force's derivative.
TEST(SiteLaw, AHeldPatchSoftensAlongThePullCurve) {
  const Organ plain(cylinder_with_sites());
  const geometry::SurfacePoint plain_at = plain.surface_tree().closest_point({0.1, 0.0, 0.05});
  SiteLaw bonded;
  ASSERT_TRUE(bonded.set(plain, plain_at, kRadius));
  const Eigen::Vector3d normal = plain.rest_normal_at(plain_at);
  SiteGrasp grasp;
  grasp.close(bonded, -0.002 * normal);
  const Eigen::Vector3d pulled = 0.008 * normal + Eigen::Vector3d(0.002, -0.001, 0.0);
  EXPECT_DOUBLE_EQ(bonded.pull_softening(0.01), 1.0);
  EXPECT_LT(
      (grasp.force(bonded, pulled) - (grasp.closing_force - bonded.stiffness() * (pulled - grasp.closed_at))).norm(),
      1e-12);

  model::OrganModel m = cylinder_with_sites();
  m.sites.pull_curve = {{{0.0, 1.0}}, {{0.006, 2.0}}, {{0.012, 3.5}}};
  m.sites.pull_tip_radius = kRadius;
  const Organ organ(std::move(m));
  const geometry::SurfacePoint at = organ.surface_tree().closest_point({0.1, 0.0, 0.05});
  SiteLaw law;
  ASSERT_TRUE(law.set(organ, at, kRadius));
  EXPECT_DOUBLE_EQ(law.pull_softening(0.003), 1.5);
  EXPECT_DOUBLE_EQ(law.pull_softening(0.009), 2.75);
  EXPECT_DOUBLE_EQ(law.pull_softening(0.05), 3.5);  // held beyond the last distance
  grasp.close(law, -0.002 * normal);
  const Eigen::Vector3d drawn = pulled - grasp.closed_at;
  const double s = law.pull_softening(drawn.norm());
  const Eigen::Matrix3d held = (law.held_stiffness(1.0).inverse() + (s - 1.0) * law.tip_compliance()).inverse();
  EXPECT_LT((grasp.force(law, pulled) - (grasp.closing_force - held * drawn)).norm(),
            1e-9 * grasp.force(law, pulled).norm());
  EXPECT_LT(grasp.force(law, pulled).norm(), grasp.force(bonded, pulled).norm()) << "softer than the bonded punch";
  const double h = 1e-8;
  Eigen::Matrix3d numeric;
  for (int k = 0; k < 3; ++k)
    numeric.col(k) = -(grasp.force(law, pulled + h * Eigen::Vector3d::Unit(k)) -
                       grasp.force(law, pulled - h * Eigen::Vector3d::Unit(k))) /
                     (2 * h);
  EXPECT_LT((grasp.tangent(law, pulled) - 0.5 * (numeric + numeric.transpose())).norm(), 1e-5 * numeric.norm());
  // A tip twice the size reads the curve at half the distance.
  SiteLaw larger;
  ASSERT_TRUE(larger.set(organ, at, 2 * kRadius));
  EXPECT_DOUBLE_EQ(larger.pull_softening(0.006), 1.5);
}

// Where the organ does not give (C_organ = 0), pressed straight in, the law
// is the sphere on a half-space: Hertz's force until the tip is buried, then
// the flat punch's slope, joined with the same value and slope; a tool that
// pulls out feels nothing.
TEST(SiteLaw, OnARigidlyHeldSurfaceTheLawIsHertzThenTheBuriedPunch) {
  model::OrganModel m = testing::make_cylinder_model({});
  m.sites.young_modulus = kYoung;
  m.sites.poisson_ratio = kPoisson;
  m.sites.compliance.assign(m.surface_vertices.size(), {});
  const Organ organ(std::move(m));
  const geometry::SurfacePoint at = organ.surface_tree().closest_point({0.1, 0.0, 0.05});
  SiteLaw law;
  ASSERT_TRUE(law.set(organ, at, kRadius));
  const Eigen::Vector3d normal = organ.rest_normal_at(at);
  for (const double depth : {1e-5, 0.0005, 0.002, 0.0025, 0.003, 0.010}) {
    SCOPED_TRACE(depth);
    EXPECT_NEAR(law.tip_indentation(depth), depth, 1e-15);
    const Eigen::Vector3d force = law.force(-depth * normal);
    EXPECT_NEAR(force.dot(normal), hertz_then_punch(depth), 1e-9 * hertz_then_punch(depth));
    EXPECT_LT((force - force.dot(normal) * normal).norm(), 1e-9 * force.norm());
    expect_tangent_is_the_derivative(law, -depth * normal);
    // Along the surface the contact radius stops growing at δ = R: a kink, no tangent to compare there.
    if (depth != kRadius)
      expect_tangent_is_the_derivative(law, -depth * normal + 0.5 * depth * normal.unitOrthogonal());
  }
  // The join at δ = R: the same force and the same slope, 2 R E*, from both sides.
  const double e_star = kYoung / (1 - kPoisson * kPoisson), h = 1e-9;
  const double below = normal.dot(law.tangent(-(kRadius - h) * normal) * normal);
  const double above = normal.dot(law.tangent(-(kRadius + h) * normal) * normal);
  EXPECT_NEAR(below, 2 * kRadius * e_star, 1e-5 * kRadius * e_star);
  EXPECT_NEAR(above, 2 * kRadius * e_star, 1e-9 * kRadius * e_star);
  // Deep in, the buried tip's secant stiffness tends to the punch's.
  EXPECT_NEAR(law.force(-0.1 * normal).dot(normal) / 0.1, normal.dot(law.stiffness() * normal),
              0.01 * normal.dot(law.stiffness() * normal));
  for (const Eigen::Vector3d& out : {Eigen::Vector3d(0.001 * normal), Eigen::Vector3d(Eigen::Vector3d::Zero())}) {
    EXPECT_EQ(law.force(out), Eigen::Vector3d::Zero());
    EXPECT_EQ(law.tangent(out), Eigen::Matrix3d::Zero());
  }
}

// On a surface of curvatures κ₁, κ₂ the tip touches as two curved bodies
// (Johnson §4.2): a ball of radius R_s under the tip is Hertz's two spheres,
// R_e = R R_s/(R + R_s), until the contact disk reaches the tip's radius at
// δ_b = R²/R_e, where the punch's slope takes over with the same force and
// slope; zero curvature is the flat law to the last bit; a concave surface
// is clipped at −1/(2R) (R_e = 2R), where the tip would start to conform.
TEST(SiteLaw, OnACurvedSurfaceTheTipTouchesAsTwoCurvedBodies) {
  auto rigid_with_curvature = [](double first, double second) {
    model::OrganModel m = testing::make_cylinder_model({});
    m.sites.young_modulus = kYoung;
    m.sites.poisson_ratio = kPoisson;
    m.sites.compliance.assign(m.surface_vertices.size(), {});
    m.sites.curvature.assign(m.surface_vertices.size(), {first, second});
    return m;
  };
  const double e_star = kYoung / (1 - kPoisson * kPoisson), ball = 0.005;
  const Organ curved(rigid_with_curvature(1 / ball, 1 / ball));
  const geometry::SurfacePoint at = curved.surface_tree().closest_point({0.1, 0.0, 0.05});
  SiteLaw law;
  ASSERT_TRUE(law.set(curved, at, kRadius));
  const Eigen::Vector3d normal = curved.rest_normal_at(at);
  const double effective = kRadius * ball / (kRadius + ball), buried = kRadius * kRadius / effective;
  for (const double depth : {1e-5, 0.0005, 0.002, 0.003, buried, 0.005, 0.010}) {
    SCOPED_TRACE(depth);
    const double expected = depth <= buried ? 4.0 / 3.0 * e_star * std::sqrt(effective) * std::pow(depth, 1.5)
                                            : 4.0 / 3.0 * e_star * std::pow(kRadius, 3) / effective +
                                                  2 * kRadius * e_star * (depth - buried);
    EXPECT_NEAR(law.force(-depth * normal).dot(normal), expected, 1e-9 * expected);
    expect_tangent_is_the_derivative(law, -depth * normal);
    if (depth != buried) expect_tangent_is_the_derivative(law, -depth * normal + 0.5 * depth * normal.unitOrthogonal());
  }
  const double h = 1e-9;
  EXPECT_NEAR(normal.dot(law.tangent(-(buried - h) * normal) * normal), 2 * kRadius * e_star, 1e-5 * kRadius * e_star);
  EXPECT_NEAR(normal.dot(law.tangent(-(buried + h) * normal) * normal), 2 * kRadius * e_star, 1e-9 * kRadius * e_star);
  // Softer than on a flat while shallow (√(R_e/R) = 0.82), the same stiffness once buried.
  const Organ flat(rigid_with_curvature(0.0, 0.0));
  SiteLaw plane;
  ASSERT_TRUE(plane.set(flat, at, kRadius));
  EXPECT_LT(law.force(-0.001 * normal).dot(normal), 0.85 * plane.force(-0.001 * normal).dot(normal));
  EXPECT_EQ(law.stiffness(), plane.stiffness());

  // No curvature section and zero curvatures: the same law, bit for bit.
  model::OrganModel without = rigid_with_curvature(0.0, 0.0);
  without.sites.curvature.clear();
  const Organ old(std::move(without));
  SiteLaw unchanged;
  ASSERT_TRUE(unchanged.set(old, at, kRadius));
  for (const Eigen::Vector3d& d :
       {Eigen::Vector3d(-0.001 * normal), Eigen::Vector3d(-0.004 * normal + Eigen::Vector3d(0.001, 0.002, 0))}) {
    EXPECT_EQ(unchanged.force(d), plane.force(d));
    EXPECT_EQ(unchanged.tangent(d), plane.tangent(d));
  }

  // Curvatures that vary over the surface follow its vertices when the
  // runtime renumbers them (the cylinder's file order is not the runtime's),
  // and are interpolated over the touched triangle: κ = 500 x (1/m, x in m) at
  // every vertex is 500 x at the touched point.
  model::OrganModel varying = rigid_with_curvature(0.0, 0.0);
  for (std::size_t v = 0; v < varying.surface_vertices.size(); ++v)
    varying.sites.curvature[v] = {500.0 * varying.surface_vertices[v][0], 500.0 * varying.surface_vertices[v][0]};
  const Organ renumbered(std::move(varying));
  ASSERT_NE(renumbered.file_vertex_index()[0], 0u);
  SiteLaw following;
  ASSERT_TRUE(following.set(renumbered, at, kRadius));
  const double kappa = 500.0 * at.position[0], shallow_depth = 0.0005;
  const double expected_radius = kRadius / (1 + kRadius * kappa);
  EXPECT_NEAR(following.force(-shallow_depth * normal).dot(normal),
              4.0 / 3.0 * e_star * std::sqrt(expected_radius) * std::pow(shallow_depth, 1.5),
              1e-9 * e_star * kRadius * shallow_depth);

  const Organ cupped(rigid_with_curvature(-10 / kRadius, -10 / kRadius));
  SiteLaw concave;
  ASSERT_TRUE(concave.set(cupped, at, kRadius));
  const double shallow = 0.0005;
  EXPECT_NEAR(concave.force(-shallow * normal).dot(normal),
              4.0 / 3.0 * e_star * std::sqrt(2 * kRadius) * std::pow(shallow, 1.5), 1e-9 * e_star * kRadius * shallow);
}

/// The contact of the fast model `name` (options `options`) whose 2.5 mm tip,
/// pointing down, touched `touch` and has been displaced by `d` for three
/// frames; nullopt when it could not attach or step.
std::optional<realtime::ContactLinearization> pressed(const char* name, const Organ& organ,
                                                      const realtime::ModelOptions& options,
                                                      const Eigen::Vector3d& touch, const Eigen::Vector3d& d) {
  geometry::ToolTip tip;
  tip.radius = kRadius;
  tip.axis = Eigen::Vector3d::UnitZ();
  const auto model = realtime::make_deformation_model(name, organ, options, 1);
  realtime::ContactLinearization contact;
  if (!model->attach(0, touch, tip, contact)) return std::nullopt;
  std::vector<model::Point3> positions(organ.vertex_count()), normals(organ.vertex_count());
  for (int frame = 0; frame < 3; ++frame)
    if (!model->step(1.0 / 60.0, &d, positions.data(), normals.data(), &contact)) return std::nullopt;
  return contact;
}

// The multi-beam and mass-spring models give a tool of finite size the site
// law's force and stiffness, and their own without site data or when told.
TEST(SiteLaw, TheFastModelsGiveTheLawsForce) {
  const Organ organ(cylinder_with_sites());
  const Eigen::Vector3d touch(0.1, 0.0, 0.03);  // on the cylinder's top (radius 0.03)
  SiteLaw law;
  ASSERT_TRUE(law.set(organ, organ.surface_tree().closest_point(touch), kRadius));
  const Eigen::Vector3d d(0.0, 0.0005, -0.003);
  for (const char* name : {"beam", "springs"})
    for (bool matched : {true, false}) {
      realtime::ModelOptions options;
      options.edit<organsim::multibeam::MultiBeamOptions>().match_sites = matched;
      options.edit<realtime::SpringModelOptions>().match_sites = matched;
      const std::optional<realtime::ContactLinearization> found = pressed(name, organ, options, touch, d);
      ASSERT_TRUE(found) << name;
      const realtime::ContactLinearization& contact = *found;
      const Eigen::Vector3d force = contact.force - contact.stiffness * (d - contact.displacement);
      if (matched) {
        EXPECT_LT((force - law.force(d)).norm(), 1e-12) << name;
        EXPECT_LT((contact.stiffness - law.tangent(d)).norm(), 1e-9 * law.stiffness().norm()) << name;
      } else {
        EXPECT_GT((force - law.force(d)).norm(), 0.1 * law.force(d).norm()) << name << ": its own force";
      }
    }
}

// On its supports (--supports baked) a press meets the site's compliance on
// the supports and a held patch drawn out meets the organ held by its clamp;
// the multi-beam and mass-spring models give that law; without compliances
// on the supports (an older file) the law is the clamp's either way.
TEST(SiteLaw, OnItsSupportsAPressMeetsTheSupportedOrganAndAGraspTheClampedOne) {
  model::OrganModel m = cylinder_with_sites();
  for (const model::Point3& p : m.surface_vertices) {
    m.supports.vertices.push_back({1.0, 2.5e5});
    m.sites.supported.push_back({0.01, 0.01, 0.02 + 0.1 * p[0], 0, 0, 0});
  }
  const Organ organ(m);
  const Eigen::Vector3d touch(0.1, 0.0, 0.03);
  const geometry::SurfacePoint at = organ.surface_tree().closest_point(touch);
  const Eigen::Vector3d normal = organ.rest_normal_at(at);
  const Eigen::Matrix3d punch = punch_compliance(kYoung, kPoisson, kRadius, normal);
  SiteLaw clamped, supported;
  ASSERT_TRUE(clamped.set(organ, at, kRadius));
  ASSERT_TRUE(supported.set(organ, at, kRadius, true));
  const Eigen::Matrix3d on_supports =
      (Eigen::Matrix3d(Eigen::Vector3d(0.01, 0.01, 0.02 + 0.1 * at.position[0]).asDiagonal()) + punch).inverse();
  EXPECT_LT((supported.stiffness() - on_supports).norm(), 1e-9 * on_supports.norm());
  EXPECT_GT(supported.stiffness()(2, 2), 2.0 * clamped.stiffness()(2, 2));
  EXPECT_LT((supported.held_stiffness(1.0) - clamped.stiffness()).norm(), 1e-9 * clamped.stiffness().norm());

  const Eigen::Vector3d d(0.0, 0.0005, -0.003);
  for (const char* name : {"beam", "springs"}) {
    realtime::ModelOptions options;
    options.edit<organsim::multibeam::MultiBeamOptions>().supports = true;
    options.edit<realtime::SpringModelOptions>().network.supports = true;
    const std::optional<realtime::ContactLinearization> contact = pressed(name, organ, options, touch, d);
    ASSERT_TRUE(contact) << name;
    EXPECT_LT((contact->force - supported.force(d)).norm(), 1e-12) << name;
  }

  m.sites.supported.clear();
  const Organ older(std::move(m));
  SiteLaw law;
  ASSERT_TRUE(law.set(older, older.surface_tree().closest_point(touch), kRadius, true));
  EXPECT_LT((law.stiffness() - clamped.stiffness()).norm(), 1e-12 * clamped.stiffness().norm());
}

// Presses on the supports read the depth curve fitted on them (read at the
// depth relative to its own tip radius), presses on the clamp alone the
// model's other curve; without a curve on the supports (a 1.7 file) both
// read the one curve.
TEST(SiteLaw, OnItsSupportsAPressReadsTheDepthCurveFittedThere) {
  model::OrganModel m = cylinder_with_sites();
  for (std::size_t v = 0; v < m.surface_vertices.size(); ++v) {
    m.supports.vertices.push_back({1.0, 2.5e5});
    m.sites.supported.push_back({0.01, 0.01, 0.02, 0, 0, 0});
  }
  m.sites.depth_curve = {{{0.0, 1.0}}, {{0.004, 1.5}}};
  m.sites.curve_tip_radius = kRadius;
  m.sites.supported_depth_curve = {{{0.0, 0.9}}, {{0.002, 0.7}}};
  m.sites.supported_curve_tip_radius = 2 * kRadius;
  const Organ organ(m);
  const geometry::SurfacePoint at = organ.surface_tree().closest_point({0.1, 0.0, 0.05});
  SiteLaw clamped, supported;
  ASSERT_TRUE(clamped.set(organ, at, kRadius));
  ASSERT_TRUE(supported.set(organ, at, kRadius, true));
  EXPECT_DOUBLE_EQ(clamped.depth_factor(0.002), 1.25);
  EXPECT_DOUBLE_EQ(supported.depth_factor(0.0005), 0.8);  // read at 1 mm: the curve's tip is twice the size
  EXPECT_DOUBLE_EQ(supported.depth_factor(0.01), 0.7);
  const Eigen::Vector3d d = -0.0005 * organ.rest_normal_at(at);
  SiteLaw linear;
  model::OrganModel without_curves = m;
  without_curves.sites.supported_depth_curve.clear();
  without_curves.sites.depth_curve.clear();
  const Organ plain(std::move(without_curves));
  ASSERT_TRUE(linear.set(plain, at, kRadius, true));
  EXPECT_LT((supported.force(d) - 0.8 * linear.force(d)).norm(), 1e-12 * linear.force(d).norm());
  expect_tangent_is_the_derivative(supported, d);

  m.sites.supported_depth_curve.clear();
  m.sites.supported_curve_tip_radius = 0.0;
  const Organ older(std::move(m));
  SiteLaw law;
  ASSERT_TRUE(law.set(older, at, kRadius, true));
  EXPECT_DOUBLE_EQ(law.depth_factor(0.002), 1.25);
}

}  // namespace
}  // namespace organsim::organ

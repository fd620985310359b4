// The clamped frame beam against closed-form cantilever results, and on an
// elastic foundation against Hetényi's beam.
#include <cmath>
#include <vector>

#include <Eigen/LU>
#include <gtest/gtest.h>

#include "beam_on_foundation.h"
#include "organsim/multibeam/clamped_beam.h"

namespace organsim::multibeam {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kE = 5000.0, kNu = 0.45;

model::BeamSection circle(double radius) {
  model::BeamSection s;
  s.area = kPi * radius * radius;
  s.i_yy = s.i_zz = kPi * std::pow(radius, 4) / 4.0;
  s.torsion_j = kPi * std::pow(radius, 4) / 2.0;
  return s;
}

struct Cantilever {
  std::vector<model::BeamSection> sections;
  ClampedBeam beam{64};
  Status build(double length, BeamBuildOptions options = {}) {
    return beam.build(sections.data(), static_cast<std::uint32_t>(sections.size()), length,
                      BeamElasticity::from(kE, kNu), options);
  }
};

TEST(ClampedBeam, TransverseTipStiffnessIsThreeEIOverLCubedForAnyElementCount) {
  const double radius = 0.03, length = 0.15;
  const model::BeamSection s = circle(radius);
  for (std::uint32_t n : {1u, 4u, 20u}) {
    Cantilever c;
    c.sections.assign(n, s);
    ASSERT_EQ(c.build(length), Status::ok);
    const double expected = 3.0 * kE * s.i_zz / std::pow(length, 3);
    EXPECT_NEAR(c.beam.tip_stiffness()(1, 1), expected, 1e-9 * expected) << n;
    EXPECT_NEAR(c.beam.tip_stiffness()(2, 2), expected, 1e-9 * expected) << n;
    EXPECT_NEAR(c.beam.tip_stiffness()(1, 2), 0.0, 1e-12 * expected) << n;
  }
}

TEST(ClampedBeam, AxialTipStiffnessIsEAOverL) {
  const double radius = 0.03, length = 0.15;
  Cantilever c;
  c.sections.assign(20, circle(radius));
  ASSERT_EQ(c.build(length), Status::ok);
  const double expected = kE * c.sections[0].area / length;
  EXPECT_NEAR(c.beam.tip_stiffness()(0, 0), expected, 1e-9 * expected);
}

TEST(ClampedBeam, TorsionalComplianceIsLOverGJ) {
  const double radius = 0.03, length = 0.15;
  Cantilever c;
  c.sections.assign(20, circle(radius));
  ASSERT_EQ(c.build(length), Status::ok);
  const Matrix6d compliance = c.beam.tip_stiffness_6x6().inverse();
  const BeamElasticity el = BeamElasticity::from(kE, kNu);
  const double expected = length / (el.shear_modulus * c.sections[0].torsion_j);  // rad per N·m
  EXPECT_NEAR(compliance(3, 3), expected, 1e-9 * expected);
  EXPECT_NEAR(compliance(3, 0), 0.0, 1e-12 * expected);
}

TEST(ClampedBeam, TimoshenkoAddsTheShearCompliance) {
  const double radius = 0.03, length = 0.10;  // short and thick: shear matters
  Cantilever c;
  c.sections.assign(20, circle(radius));
  BeamBuildOptions options;
  options.theory = BeamTheory::timoshenko;
  ASSERT_EQ(c.build(length, options), Status::ok);
  const BeamElasticity el = BeamElasticity::from(kE, kNu);
  const model::BeamSection& s = c.sections[0];
  const double compliance =
      std::pow(length, 3) / (3.0 * kE * s.i_zz) + length / (el.shear_coefficient * el.shear_modulus * s.area);
  EXPECT_NEAR(c.beam.tip_stiffness()(1, 1), 1.0 / compliance, 1e-9 / compliance);
  // Softer than Euler–Bernoulli by the shear term (here about 11 %).
  const double bending_only = 3.0 * kE * s.i_zz / std::pow(length, 3);
  EXPECT_LT(c.beam.tip_stiffness()(1, 1), 0.95 * bending_only);
}

TEST(ClampedBeam, TaperedBeamConvergesUnderRefinement) {
  // I(x) = I0 (1 + x/L): tip compliance L³ (4 ln 2 − 5/2) / (E I0) for a tip load.
  const double length = 0.12, i0 = 1e-7;
  const double exact = std::pow(length, 3) * (4.0 * std::log(2.0) - 2.5) / (kE * i0);
  double previous_error = 1.0;
  for (std::uint32_t n : {5u, 10u, 20u, 40u}) {
    Cantilever c;
    for (std::uint32_t e = 0; e < n; ++e) {
      model::BeamSection s;
      s.area = 1e-3;
      s.i_yy = s.i_zz = i0 * (1.0 + (e + 0.5) / n);
      s.torsion_j = 2.0 * s.i_yy;
      c.sections.push_back(s);
    }
    ASSERT_EQ(c.build(length), Status::ok);
    const double error = std::abs(1.0 / c.beam.tip_stiffness()(1, 1) - exact) / exact;
    EXPECT_LT(error, 0.3 * previous_error) << n;  // second order: ×¼ per halving
    previous_error = error;
  }
  EXPECT_LT(previous_error, 3e-4);  // 40 elements
}

TEST(ClampedBeam, ProductOfInertiaBendsOutOfTheLoadPlane) {
  // Tip compliance in the section plane is L³/(3E) Q⁻¹, Q = [[∫y², ∫yz], [∫yz, ∫z²]].
  const double length = 0.15;
  model::BeamSection s;
  s.area = 2e-3;
  s.i_zz = 4e-7;  // ∫y²
  s.i_yy = 1e-7;  // ∫z²
  s.i_yz = 1.5e-7;
  s.torsion_j = 2e-7;
  Cantilever c;
  c.sections.assign(20, s);
  ASSERT_EQ(c.build(length), Status::ok);
  Eigen::Matrix2d q;
  q << s.i_zz, s.i_yz, s.i_yz, s.i_yy;
  const Eigen::Matrix2d expected = 3.0 * kE / std::pow(length, 3) * q;
  const Eigen::Matrix2d actual = c.beam.tip_stiffness().block<2, 2>(1, 1);
  EXPECT_LT((actual - expected).norm(), 1e-9 * expected.norm());
  // A force along y alone moves the tip along z too, as theory says.
  const Eigen::Vector3d tip = c.beam.tip_stiffness().inverse() * Eigen::Vector3d(0.0, 1.0, 0.0);
  const Eigen::Vector2d theory = std::pow(length, 3) / (3.0 * kE) * q.inverse() * Eigen::Vector2d(1.0, 0.0);
  EXPECT_NEAR(tip[1], theory[0], 1e-9 * std::abs(theory[0]));
  EXPECT_NEAR(tip[2], theory[1], 1e-9 * std::abs(theory[0]));
  EXPECT_LT(tip[2], -0.1 * tip[1]);
}

TEST(ClampedBeam, EccentricSectionCouplesAxialPushAndBending) {
  // Centroid at offset e along y: an axial tip load P on the reference axis is
  // P on the centroid plus a moment e P, so the compliance has
  // C_xx = L/EA + e² L/(E I), C_xy = e L²/(2 E I), C_yy = L³/(3 E I).
  const double length = 0.15, e = 0.01;
  model::BeamSection s = circle(0.03);
  s.centroid_y = e;
  Cantilever c;
  c.sections.assign(20, s);
  ASSERT_EQ(c.build(length), Status::ok);
  const Eigen::Matrix3d compliance = c.beam.tip_stiffness().inverse();
  const double ei = kE * s.i_zz;
  EXPECT_NEAR(compliance(0, 0), length / (kE * s.area) + e * e * length / ei, 1e-9 * compliance(0, 0));
  EXPECT_NEAR(compliance(0, 1), e * length * length / (2.0 * ei), 1e-9 * compliance(0, 0));
  EXPECT_NEAR(compliance(1, 1), std::pow(length, 3) / (3.0 * ei), 1e-9 * compliance(1, 1));
  EXPECT_NEAR(compliance(0, 2), 0.0, 1e-12 * compliance(0, 0));
  // Without the offsets the same sections give the centred beam.
  BeamBuildOptions centred;
  centred.centroid_offsets = false;
  ASSERT_EQ(c.build(length, centred), Status::ok);
  EXPECT_NEAR(c.beam.tip_stiffness()(0, 0), kE * s.area / length, 1e-9 * kE * s.area / length);
}

TEST(ClampedBeam, NodeResponseIsTheCantileverDeflectionCurve) {
  // Tip displacement d along y with a free tip rotation: v(x) = d (3 (x/L)² − (x/L)³) / 2.
  const double length = 0.2;
  Cantilever c;
  c.sections.assign(10, circle(0.02));
  ASSERT_EQ(c.build(length), Status::ok);
  for (std::uint32_t node = 0; node <= 10; ++node) {
    const double s = node / 10.0;
    const NodeResponse& r = c.beam.node_response(node);
    EXPECT_NEAR(r(1, 1), (3.0 * s * s - s * s * s) / 2.0, 1e-9) << node;
    EXPECT_NEAR(r(5, 1), (6.0 * s - 3.0 * s * s) / (2.0 * length), 1e-9 / length) << node;  // θz = v'
    EXPECT_NEAR(r(0, 0), s, 1e-9) << node;                                                  // axial: linear
  }
}

// On a Winkler foundation (k per metre, lumped at the nodes: k h, the tip's
// half) the beam is Hetényi's: its transverse tip stiffness is 1 / w(L) and a
// tip displacement bends it along w(x) / w(L), which the foundation makes
// fall off toward the clamp faster than the cantilever's curve; the axial
// stiffness, which the foundation does not hold, is unchanged.
TEST(ClampedBeam, OnAnElasticFoundationItIsHetenyisBeam) {
  const double length = 0.15;
  const model::BeamSection s = circle(0.02);
  const double ei = kE * s.i_zz, k = 4 * ei * std::pow(3.0 / length, 4);  // λL = 3
  constexpr std::uint32_t kElements = 40;
  const double h = length / kElements;
  std::vector<Eigen::Matrix3d> foundation(kElements, Eigen::Vector3d(0.0, k * h, k * h).asDiagonal());
  foundation.back() *= 0.5;
  Cantilever free, supported;
  free.sections.assign(kElements, s);
  supported.sections.assign(kElements, s);
  ASSERT_EQ(free.build(length), Status::ok);
  ASSERT_EQ(supported.beam.build(supported.sections.data(), kElements, length, BeamElasticity::from(kE, kNu), {},
                                 foundation.data()),
            Status::ok);
  const double tip = testing::hetenyi_deflection(length, length, ei, k);
  EXPECT_NEAR(supported.beam.tip_stiffness()(1, 1) * tip, 1.0, 0.005);
  EXPECT_NEAR(supported.beam.tip_stiffness()(2, 2) * tip, 1.0, 0.005);
  EXPECT_GT(supported.beam.tip_stiffness()(1, 1), 3.0 * free.beam.tip_stiffness()(1, 1));
  EXPECT_NEAR(supported.beam.tip_stiffness()(0, 0), free.beam.tip_stiffness()(0, 0),
              1e-9 * free.beam.tip_stiffness()(0, 0));
  for (std::uint32_t node = 1; node <= kElements; ++node) {
    const double x = node * h, shape = testing::hetenyi_deflection(x, length, ei, k) / tip;
    EXPECT_NEAR(supported.beam.node_response(node)(1, 1), shape, 0.005) << node;
  }
  EXPECT_LT(supported.beam.node_response(kElements / 2)(1, 1), 0.5 * free.beam.node_response(kElements / 2)(1, 1));
  foundation[3](1, 1) = std::nan("");
  EXPECT_EQ(supported.beam.build(supported.sections.data(), kElements, length, BeamElasticity::from(kE, kNu), {},
                                 foundation.data()),
            Status::not_finite);
}

TEST(ClampedBeam, BadInputGivesAStatusNotNaN) {
  Cantilever c;
  c.sections.assign(20, circle(0.03));
  EXPECT_EQ(c.build(std::nan("")), Status::not_finite);
  EXPECT_EQ(c.build(-1.0), Status::not_finite);
  c.sections[3].i_yy = std::numeric_limits<double>::infinity();
  EXPECT_EQ(c.build(0.1), Status::not_finite);
  c.sections.assign(20, model::BeamSection{});
  EXPECT_EQ(c.build(0.1), Status::singular_beam);
  EXPECT_FALSE(c.beam.built());
  c.sections.assign(65, circle(0.03));  // more elements than reserved
  EXPECT_EQ(c.build(0.1), Status::singular_beam);
}

TEST(ClampedBeam, EmptySectionsAreFlooredNotSingular) {
  Cantilever c;
  c.sections.assign(20, circle(0.03));
  c.sections[19] = model::BeamSection{};  // a section plane that misses the organ
  ASSERT_EQ(c.build(0.15), Status::ok);
  EXPECT_TRUE(c.beam.tip_stiffness().allFinite());
  EXPECT_GT(c.beam.tip_stiffness()(1, 1), 0.0);
}

}  // namespace
}  // namespace organsim::multibeam

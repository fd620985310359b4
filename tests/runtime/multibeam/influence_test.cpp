// The influence function that merges several beams' displacement fields (paper
// 000, eqs. 7–8), checked against the definition f(p) = L⁻¹ l(p) / ‖L⁻¹ l(p)‖₁
// evaluated independently here, against closed forms worked out by hand, and
// against each promise of influence.h.
#include <array>
#include <cmath>
#include <limits>
#include <random>
#include <type_traits>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "organsim/multibeam/influence.h"

namespace organsim::multibeam {
namespace {

// The definition, evaluated with a different factorization (Householder QR on
// a freshly built distance matrix) than the one under test (a stored LU
// inverse), so that agreement is not the same rounding twice.
std::vector<double> reference_weights(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& p) {
  const auto n = static_cast<Eigen::Index>(points.size());
  Eigen::MatrixXd distances(n, n);
  Eigen::VectorXd l(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    l[i] = (p - points[i]).norm();
    for (Eigen::Index j = 0; j < n; ++j) distances(i, j) = (points[i] - points[j]).norm();
  }
  const Eigen::VectorXd raw = distances.colPivHouseholderQr().solve(l);
  const Eigen::VectorXd f = raw / raw.lpNorm<1>();
  return {f.data(), f.data() + n};
}

std::vector<double> weights_at(const InfluenceFunction& f, const Eigen::Vector3d& p) {
  std::vector<double> w(f.count());
  f.weights(p, w.data());
  return w;
}

double one_norm(const std::vector<double>& w) {
  double sum = 0.0;
  for (double x : w) sum += std::abs(x);
  return sum;
}

// A handful of probe points around and between the action points used below
// (centimetres from them, like vertices of an organ around its tools).
const std::vector<Eigen::Vector3d>& probes() {
  static const std::vector<Eigen::Vector3d> p = {
      {0.01, 0.03, 0.0},   {-0.2, 0.1, 0.3},  {0.02, 0.01, 0.005}, {0.0, 0.01, -0.01},  {0.05, 0.05, 0.05},
      {-0.03, -0.02, 0.0}, {0.025, 0.0, 0.0}, {0.1, -0.1, 0.02},   {0.015, 0.02, 0.03}, {1.0, 2.0, -3.0},
  };
  return p;
}

TEST(InfluenceWeights, StorageIsInlineSoTheFunctionNeverAllocates) {
  // "Allocates nothing": L⁻¹ lives in a fixed-capacity Eigen matrix (at most
  // kMaxTools × kMaxTools, stored inside the object) and the calls are noexcept.
  // The allocation count itself is measured in no_allocation_test (MultiBeam
  // calls set_points on every prepare).
  static_assert(InfluenceFunction::Matrix::MaxRowsAtCompileTime == kMaxTools);
  static_assert(InfluenceFunction::Matrix::MaxColsAtCompileTime == kMaxTools);
  static_assert(sizeof(InfluenceFunction) >=
                kMaxTools * kMaxTools * sizeof(double) + kMaxTools * sizeof(Eigen::Vector3d));
  InfluenceFunction f;
  const Eigen::Vector3d points[2] = {{0.0, 0.0, 0.0}, {0.01, 0.0, 0.0}};
  double w[2];
  static_assert(noexcept(f.set_points(points, 2)));
  static_assert(noexcept(f.weights(points[0], w)));
  static_assert(noexcept(normalize_influence(w, 2)));
  EXPECT_EQ(kMaxTools, 16u);
  EXPECT_EQ(f.count(), 0u);  // nothing set yet
}

TEST(InfluenceWeights, OnePointHasTheIdentityInverseAndWeightOneEverywhere) {
  const Eigen::Vector3d point(0.02, -0.01, 0.03);
  InfluenceFunction f;
  ASSERT_TRUE(f.set_points(&point, 1));
  EXPECT_EQ(f.count(), 1u);
  ASSERT_EQ(f.inverse_distances().rows(), 1);
  ASSERT_EQ(f.inverse_distances().cols(), 1);
  EXPECT_EQ(f.inverse_distances()(0, 0), 1.0);
  // At the point itself L⁻¹ l = 0 (a zero distance): the single weight is still 1.
  EXPECT_EQ(weights_at(f, point)[0], 1.0);
  for (const Eigen::Vector3d& p : probes()) EXPECT_EQ(weights_at(f, p)[0], 1.0);
}

TEST(InfluenceWeights, TwoPointsMatchEquationEightWorkedOutByHand) {
  // L = [[0, d], [d, 0]], so L⁻¹ = [[0, 1/d], [1/d, 0]] and L⁻¹ l(p) = [l₂, l₁]/d;
  // both entries are non-negative, so ‖·‖₁ = (l₁ + l₂)/d and f = [l₂, l₁]/(l₁ + l₂).
  const Eigen::Vector3d points[2] = {{0.01, 0.02, 0.0}, {0.04, -0.02, 0.012}};
  InfluenceFunction f;
  ASSERT_TRUE(f.set_points(points, 2));
  const double d = (points[0] - points[1]).norm();
  EXPECT_EQ(f.inverse_distances()(0, 0), 0.0);
  EXPECT_EQ(f.inverse_distances()(1, 1), 0.0);
  EXPECT_NEAR(f.inverse_distances()(0, 1), 1.0 / d, 1e-12 / d);
  EXPECT_NEAR(f.inverse_distances()(1, 0), 1.0 / d, 1e-12 / d);
  for (const Eigen::Vector3d& p : probes()) {
    const double l1 = (p - points[0]).norm(), l2 = (p - points[1]).norm();
    const std::vector<double> w = weights_at(f, p);
    EXPECT_NEAR(w[0], l2 / (l1 + l2), 1e-14) << p.transpose();
    EXPECT_NEAR(w[1], l1 / (l1 + l2), 1e-14) << p.transpose();
  }
  // Hand-picked values: the midpoint is shared equally; a point on the line a
  // quarter of the way from p₁ gets f = [3/4, 1/4]; one beyond p₂ at distance d
  // from it (2d from p₁) gets f = [1/3, 2/3].
  const Eigen::Vector3d along = points[1] - points[0];
  std::vector<double> w = weights_at(f, points[0] + 0.5 * along);
  EXPECT_NEAR(w[0], 0.5, 1e-15);
  EXPECT_NEAR(w[1], 0.5, 1e-15);
  w = weights_at(f, points[0] + 0.25 * along);
  EXPECT_NEAR(w[0], 0.75, 1e-15);
  EXPECT_NEAR(w[1], 0.25, 1e-15);
  w = weights_at(f, points[0] + 2.0 * along);
  EXPECT_NEAR(w[0], 1.0 / 3.0, 1e-15);
  EXPECT_NEAR(w[1], 2.0 / 3.0, 1e-15);
  // Equidistant from both (the bisecting plane, far off the segment): ½ each.
  const Eigen::Vector3d normal = along.unitOrthogonal();
  w = weights_at(f, points[0] + 0.5 * along + 0.3 * normal);
  EXPECT_NEAR(w[0], 0.5, 1e-12);
  EXPECT_NEAR(w[1], 0.5, 1e-12);
}

TEST(InfluenceWeights, TwoPointsGiveExactUnitVectorsAtTheActionPoints) {
  // For N = 2 the inverse has exact zeros on its diagonal, so f(p_i) = e_i holds
  // bit for bit (a weight of exactly 0 for the other tool, not 1e-17).
  const Eigen::Vector3d points[2] = {{0.0, 0.0, 0.0}, {0.05, 0.02, -0.01}};
  InfluenceFunction f;
  ASSERT_TRUE(f.set_points(points, 2));
  const std::vector<double> w0 = weights_at(f, points[0]), w1 = weights_at(f, points[1]);
  EXPECT_EQ(w0[0], 1.0);
  EXPECT_EQ(w0[1], 0.0);
  EXPECT_EQ(w1[0], 0.0);
  EXPECT_EQ(w1[1], 1.0);
}

TEST(InfluenceWeights, EquilateralTriangleSharesItsCentroidEqually) {
  // L = s (J − I) for side s, whose inverse is (J/2 − I)/s; at the centroid
  // l = (s/√3)·1, so L⁻¹ l = 1/(2√3)·1 > 0 and f = [1/3, 1/3, 1/3].
  const double s = 0.03;
  const Eigen::Vector3d points[3] = {{0.0, 0.0, 0.0}, {s, 0.0, 0.0}, {0.5 * s, 0.5 * std::sqrt(3.0) * s, 0.0}};
  InfluenceFunction f;
  ASSERT_TRUE(f.set_points(points, 3));
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      EXPECT_NEAR(f.inverse_distances()(i, j), (0.5 - (i == j ? 1.0 : 0.0)) / s, 1e-10) << i << j;
  const Eigen::Vector3d centroid = (points[0] + points[1] + points[2]) / 3.0;
  for (double w : weights_at(f, centroid)) EXPECT_NEAR(w, 1.0 / 3.0, 1e-14);
  // Any point on the triangle's axis (above or below the centroid) is also
  // equidistant from all three points.
  for (double w : weights_at(f, centroid + Eigen::Vector3d(0.0, 0.0, -0.07))) EXPECT_NEAR(w, 1.0 / 3.0, 1e-14);
}

TEST(InfluenceWeights, ThreeAndFourPointsMatchTheDefinition) {
  const std::vector<std::vector<Eigen::Vector3d>> configurations = {
      // A scalene triangle, a collinear triple (the distance matrix of distinct
      // points is invertible even when they are collinear), a tetrahedron.
      {{0.0, 0.0, 0.0}, {0.04, 0.0, 0.0}, {0.01, 0.03, 0.0}},
      {{0.0, 0.0, 0.0}, {0.01, 0.0, 0.0}, {0.035, 0.0, 0.0}},
      {{0.0, 0.0, 0.0}, {0.05, 0.0, 0.0}, {0.0, 0.04, 0.01}, {0.03, 0.03, 0.05}},
      {{0.012, -0.004, 0.02}, {-0.02, 0.03, 0.0}, {0.0, 0.0, -0.015}, {0.025, 0.025, 0.025}},
  };
  for (const auto& points : configurations) {
    InfluenceFunction f;
    const auto n = static_cast<std::uint32_t>(points.size());
    ASSERT_TRUE(f.set_points(points.data(), n));
    EXPECT_EQ(f.count(), n);
    for (std::uint32_t i = 0; i < n; ++i) EXPECT_EQ(f.point(i), points[i]);  // stored as given
    // L⁻¹ really is the inverse of the distance matrix.
    Eigen::MatrixXd distances(n, n);
    for (std::uint32_t i = 0; i < n; ++i)
      for (std::uint32_t j = 0; j < n; ++j) distances(i, j) = (points[i] - points[j]).norm();
    const Eigen::MatrixXd product = f.inverse_distances() * distances;
    EXPECT_TRUE(product.isApprox(Eigen::MatrixXd::Identity(n, n), 1e-12)) << product;
    for (const Eigen::Vector3d& p : probes()) {
      const std::vector<double> w = weights_at(f, p), expected = reference_weights(points, p);
      for (std::uint32_t i = 0; i < n; ++i) EXPECT_NEAR(w[i], expected[i], 1e-12) << n << " tools, weight " << i;
    }
  }
}

TEST(InfluenceWeights, CollinearTripleInterpolatesLikeHatFunctions) {
  // On the line through x = 0, 1, 3 cm the distances are piecewise linear in x
  // and so is f: between neighbouring points only those two share the weight,
  // linearly (for N = 3 worked out from L⁻¹ by hand: at x = 2 cm, f = [0, ½, ½]).
  const Eigen::Vector3d points[3] = {{0.0, 0.0, 0.0}, {0.01, 0.0, 0.0}, {0.03, 0.0, 0.0}};
  InfluenceFunction f;
  ASSERT_TRUE(f.set_points(points, 3));
  std::vector<double> w = weights_at(f, {0.005, 0.0, 0.0});
  EXPECT_NEAR(w[0], 0.5, 1e-13);
  EXPECT_NEAR(w[1], 0.5, 1e-13);
  EXPECT_NEAR(w[2], 0.0, 1e-13);
  w = weights_at(f, {0.02, 0.0, 0.0});
  EXPECT_NEAR(w[0], 0.0, 1e-13);
  EXPECT_NEAR(w[1], 0.5, 1e-13);
  EXPECT_NEAR(w[2], 0.5, 1e-13);
  w = weights_at(f, {0.015, 0.0, 0.0});
  EXPECT_NEAR(w[0], 0.0, 1e-13);
  EXPECT_NEAR(w[1], 0.75, 1e-13);
  EXPECT_NEAR(w[2], 0.25, 1e-13);
}

TEST(InfluenceWeights, UnitVectorsAtTheActionPointsForUpToSixteenTools) {
  // f(p_i) = e_i: exact in exact arithmetic; the stored inverse carries the
  // rounding of the LU, so off-diagonal weights come out at the 1e-16 level.
  for (std::uint32_t n : {3u, 4u, 7u, kMaxTools}) {
    std::vector<Eigen::Vector3d> points(n);
    for (std::uint32_t i = 0; i < n; ++i) {
      // Distinct points on a twisted curve (a few centimetres apart).
      const double t = static_cast<double>(i);
      points[i] = {0.01 * t, 0.03 * std::sin(0.9 * t), 0.02 * std::cos(1.3 * t)};
    }
    InfluenceFunction f;
    ASSERT_TRUE(f.set_points(points.data(), n));
    for (std::uint32_t i = 0; i < n; ++i) {
      const std::vector<double> w = weights_at(f, points[i]);
      for (std::uint32_t j = 0; j < n; ++j) EXPECT_NEAR(w[j], i == j ? 1.0 : 0.0, 1e-10) << n << " " << i << " " << j;
    }
  }
}

TEST(InfluenceWeights, NormalizedToUnitOneNormNotToUnitSum) {
  // The documented normalization is ‖f‖₁ = 1. Where every weight is
  // non-negative (always for N = 2) that is Σ f_i = 1; but for N ≥ 4 L⁻¹ l(p)
  // can have a negative entry, and there the signed sum is below 1. This pins
  // the definition (eq. 7) rather than a partition of unity.
  const std::vector<Eigen::Vector3d> points = {
      {0.0, 0.0, 0.0}, {0.05, 0.0, 0.0}, {0.0, 0.04, 0.01}, {0.03, 0.03, 0.05}};
  InfluenceFunction f;
  ASSERT_TRUE(f.set_points(points.data(), 4));
  for (const Eigen::Vector3d& p : probes()) EXPECT_NEAR(one_norm(weights_at(f, p)), 1.0, 1e-14);
  const Eigen::Vector3d p(0.0, 0.01, -0.01);  // 1.4 cm from p₁, below the others
  const std::vector<double> w = weights_at(f, p), expected = reference_weights(points, p);
  EXPECT_LT(w[3], -0.01);  // ≈ −0.039
  EXPECT_NEAR(w[3], expected[3], 1e-12);
  EXPECT_NEAR(one_norm(w), 1.0, 1e-14);
  EXPECT_LT(w[0] + w[1] + w[2] + w[3], 0.95);  // ≈ 0.92

  const Eigen::Vector3d pair[2] = {points[0], points[1]};
  ASSERT_TRUE(f.set_points(pair, 2));
  for (const Eigen::Vector3d& q : probes()) {
    const std::vector<double> v = weights_at(f, q);
    EXPECT_GE(v[0], 0.0);
    EXPECT_GE(v[1], 0.0);
    EXPECT_NEAR(v[0] + v[1], 1.0, 1e-15);
  }
}

TEST(InfluenceWeights, PermutingTheActionPointsPermutesTheWeights) {
  const std::vector<Eigen::Vector3d> points = {
      {0.012, -0.004, 0.02}, {-0.02, 0.03, 0.0}, {0.0, 0.0, -0.015}, {0.025, 0.025, 0.025}};
  const std::array<std::uint32_t, 4> order = {2, 0, 3, 1};  // permuted[k] = points[order[k]]
  std::vector<Eigen::Vector3d> permuted(4);
  for (std::size_t k = 0; k < 4; ++k) permuted[k] = points[order[k]];
  InfluenceFunction f, g;
  ASSERT_TRUE(f.set_points(points.data(), 4));
  ASSERT_TRUE(g.set_points(permuted.data(), 4));
  for (const Eigen::Vector3d& p : probes()) {
    const std::vector<double> w = weights_at(f, p), v = weights_at(g, p);
    for (std::size_t k = 0; k < 4; ++k) EXPECT_NEAR(v[k], w[order[k]], 1e-13) << k;
  }
}

TEST(InfluenceWeights, InvariantUnderRigidMotionAndScale) {
  // f depends only on distance ratios: rotating, translating and scaling the
  // action points and the probe together leaves it unchanged.
  const std::vector<Eigen::Vector3d> points = {{0.0, 0.0, 0.0}, {0.04, 0.0, 0.0}, {0.01, 0.03, 0.0}};
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1.0, 2.0, -1.0).normalized()).toRotationMatrix();
  const Eigen::Vector3d shift(0.1, -0.2, 0.05);
  const double scale = 3.5;
  auto move = [&](const Eigen::Vector3d& x) -> Eigen::Vector3d { return scale * (rotation * x) + shift; };
  std::vector<Eigen::Vector3d> moved;
  for (const auto& x : points) moved.push_back(move(x));
  InfluenceFunction f, g;
  ASSERT_TRUE(f.set_points(points.data(), 3));
  ASSERT_TRUE(g.set_points(moved.data(), 3));
  for (const Eigen::Vector3d& p : probes()) {
    const std::vector<double> w = weights_at(f, p), v = weights_at(g, move(p));
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(v[i], w[i], 1e-12);
  }
}

TEST(InfluenceWeights, ContinuousAcrossTheActionPoints) {
  // Approaching p_i from any direction the weights tend to e_i, at a rate
  // proportional to the distance (f is Lipschitz: distances are).
  const std::vector<Eigen::Vector3d> points = {
      {0.0, 0.0, 0.0}, {0.05, 0.0, 0.0}, {0.0, 0.04, 0.01}, {0.03, 0.03, 0.05}};
  InfluenceFunction f;
  ASSERT_TRUE(f.set_points(points.data(), 4));
  const Eigen::Vector3d directions[3] = {
      Eigen::Vector3d(1.0, 1.0, 1.0).normalized(), Eigen::Vector3d(-1.0, 0.0, 0.2).normalized(), {0.0, 0.0, -1.0}};
  for (std::uint32_t i = 0; i < 4; ++i)
    for (const Eigen::Vector3d& direction : directions) {
      double previous_error = std::numeric_limits<double>::infinity();
      for (double h : {1e-3, 1e-5, 1e-7}) {
        const std::vector<double> w = weights_at(f, points[i] + h * direction);
        double error = 0.0;
        for (std::uint32_t j = 0; j < 4; ++j) error = std::max(error, std::abs(w[j] - (i == j ? 1.0 : 0.0)));
        EXPECT_LT(error, 200.0 * h) << i << " h = " << h;  // O(h), constant ~ 1/(spacing)
        EXPECT_LT(error, previous_error);
        previous_error = error;
      }
    }
}

TEST(InfluenceWeights, RefusesBadInputAndLeavesNoPointsSet) {
  const Eigen::Vector3d good[3] = {{0.0, 0.0, 0.0}, {0.02, 0.0, 0.0}, {0.0, 0.02, 0.0}};
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  InfluenceFunction f;
  ASSERT_TRUE(f.set_points(good, 3));
  ASSERT_EQ(f.count(), 3u);

  EXPECT_FALSE(f.set_points(good, 0));  // no points
  EXPECT_EQ(f.count(), 0u);

  Eigen::Vector3d many[kMaxTools + 1];
  for (std::uint32_t i = 0; i <= kMaxTools; ++i) many[i] = {0.01 * i, 0.001 * i * i, 0.0};
  EXPECT_TRUE(f.set_points(many, kMaxTools));  // the most allowed
  EXPECT_FALSE(f.set_points(many, kMaxTools + 1));
  EXPECT_EQ(f.count(), 0u);

  for (const double bad : {nan, inf, -inf}) {
    ASSERT_TRUE(f.set_points(good, 3));
    const Eigen::Vector3d with_bad[3] = {good[0], {0.02, bad, 0.0}, good[2]};
    EXPECT_FALSE(f.set_points(with_bad, 3)) << bad;
    EXPECT_EQ(f.count(), 0u);
  }
  // No weights are written while no points are set.
  double untouched[3] = {7.0, 7.0, 7.0};
  f.weights({0.01, 0.01, 0.0}, untouched);
  EXPECT_EQ(untouched[0], 7.0);
}

TEST(InfluenceWeights, CoincidingPointsAreRefusedAndMergedPointsGiveFiniteWeights) {
  // Coinciding action points make L singular (two equal rows): set_points
  // refuses them, and the header's remedy is to merge them first (MultiBeam
  // merges points within merge_distance into one group that its tools share).
  const Eigen::Vector3d a(0.01, 0.0, 0.0), b(0.0, 0.03, 0.0), c(-0.02, 0.0, 0.01);
  const Eigen::Vector3d with_duplicate[4] = {a, b, a, c};
  InfluenceFunction f;
  EXPECT_FALSE(f.set_points(with_duplicate, 4));
  EXPECT_EQ(f.count(), 0u);
  const Eigen::Vector3d pair[2] = {b, b};
  EXPECT_FALSE(f.set_points(pair, 2));

  const std::vector<Eigen::Vector3d> merged = {a, b, c};
  ASSERT_TRUE(f.set_points(merged.data(), 3));
  EXPECT_TRUE(f.inverse_distances().allFinite());
  for (const Eigen::Vector3d& p : probes()) {
    const std::vector<double> w = weights_at(f, p), expected = reference_weights(merged, p);
    for (int i = 0; i < 3; ++i) {
      EXPECT_TRUE(std::isfinite(w[i]));
      EXPECT_NEAR(w[i], expected[i], 1e-12);
    }
  }
  // The merged group's weight is 1 at the shared point, as for any action point.
  const std::vector<double> at_a = weights_at(f, a);
  EXPECT_NEAR(at_a[0], 1.0, 1e-12);
  EXPECT_NEAR(at_a[1], 0.0, 1e-12);
  EXPECT_NEAR(at_a[2], 0.0, 1e-12);
}

TEST(InfluenceWeights, NormalizeInfluenceDividesByTheOneNorm) {
  double v[4] = {1.0, -3.0, 4.0, 0.0};
  normalize_influence(v, 4);
  EXPECT_EQ(v[0], 0.125);
  EXPECT_EQ(v[1], -0.375);
  EXPECT_EQ(v[2], 0.5);
  EXPECT_EQ(v[3], 0.0);
  // Already normalized: unchanged.
  double u[2] = {0.25, 0.75};
  normalize_influence(u, 2);
  EXPECT_EQ(u[0], 0.25);
  EXPECT_EQ(u[1], 0.75);
  // Scale-free: 1e-300 and 1e300 magnitudes give the same result.
  double tiny[2] = {1e-300, 3e-300}, huge[2] = {1e300, 3e300};
  normalize_influence(tiny, 2);
  normalize_influence(huge, 2);
  EXPECT_DOUBLE_EQ(tiny[0], 0.25);
  EXPECT_DOUBLE_EQ(huge[1], 0.75);
}

TEST(InfluenceFunction, WeightsAreUnitVectorsAtTheActionPoints) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> coordinate(-0.1, 0.1);
  for (std::uint32_t n = 1; n <= 8; ++n) {
    Eigen::Vector3d points[kMaxTools];
    for (std::uint32_t i = 0; i < n; ++i) points[i] = {coordinate(random), coordinate(random), coordinate(random)};
    InfluenceFunction f;
    ASSERT_TRUE(f.set_points(points, n));
    double w[kMaxTools];
    for (std::uint32_t i = 0; i < n; ++i) {
      f.weights(points[i], w);
      for (std::uint32_t j = 0; j < n; ++j) EXPECT_NEAR(w[j], i == j ? 1.0 : 0.0, 1e-9) << n << " " << i << " " << j;
    }
  }
}

TEST(InfluenceFunction, TwoToolsReduceToEquationEight) {
  const Eigen::Vector3d points[2] = {{0.0, 0.0, 0.0}, {0.05, 0.02, -0.01}};
  InfluenceFunction f;
  ASSERT_TRUE(f.set_points(points, 2));
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(0.01, 0.03, 0.0), Eigen::Vector3d(-0.2, 0.1, 0.3)}) {
    const double l1 = (p - points[0]).norm(), l2 = (p - points[1]).norm();
    double w[2];
    f.weights(p, w);
    EXPECT_NEAR(w[0], l2 / (l1 + l2), 1e-12);
    EXPECT_NEAR(w[1], l1 / (l1 + l2), 1e-12);
  }
}

TEST(InfluenceFunction, WeightsAreContinuous) {
  const Eigen::Vector3d points[4] = {{0.0, 0.0, 0.0}, {0.05, 0.0, 0.0}, {0.0, 0.04, 0.01}, {0.03, 0.03, 0.05}};
  InfluenceFunction f;
  ASSERT_TRUE(f.set_points(points, 4));
  std::mt19937 random(3);
  std::uniform_real_distribution<double> coordinate(-0.05, 0.1);
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector3d p(coordinate(random), coordinate(random), coordinate(random));
    const Eigen::Vector3d q = p + Eigen::Vector3d(1e-7, -1e-7, 1e-7);
    double wp[4], wq[4];
    f.weights(p, wp);
    f.weights(q, wq);
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(wp[i], wq[i], 1e-4) << trial;
  }
}

TEST(InfluenceFunction, RefusesCoincidingAndNonFinitePoints) {
  const Eigen::Vector3d same[2] = {{0.01, 0.0, 0.0}, {0.01, 0.0, 0.0}};
  InfluenceFunction f;
  EXPECT_FALSE(f.set_points(same, 2));
  const Eigen::Vector3d bad[2] = {{0.01, 0.0, 0.0}, {std::nan(""), 0.0, 0.0}};
  EXPECT_FALSE(f.set_points(bad, 2));
  EXPECT_FALSE(f.set_points(same, 0));
}

}  // namespace
}  // namespace organsim::multibeam

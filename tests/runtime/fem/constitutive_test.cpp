// The materials' stress is the derivative of their energy, their tangent the
// derivative of their stress (central differences), rotations cause no stress,
// and co-rotational equals linear at small strain; the co-rotational stress in
// SIMD lanes equals the one-at-a-time stress.
#include "constitutive.h"

#include <gtest/gtest.h>

#include <array>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

namespace organsim::fem {
namespace {

using Eigen::Matrix3d;

Constitutive material_for(MaterialModel model) {
  Material m = model == MaterialModel::mooney_rivlin ? Material::mooney_rivlin_from_young(1e6, 0.45, 0)
                                                     : Material::from_young(model, 1e6, 0.3);
  return Constitutive(m);
}

const MaterialModel kModels[] = {MaterialModel::linear, MaterialModel::corotational, MaterialModel::stvk,
                                 MaterialModel::mooney_rivlin};

/// A deformation gradient with 10–30 % strain and a rotation, det > 0.
Matrix3d strained_gradient() {
  Matrix3d stretch;
  stretch << 1.2, 0.1, -0.05, 0.03, 0.85, 0.12, -0.08, 0.04, 1.1;
  return Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix() * stretch;
}

TEST(Constitutive, StressIsTheEnergysDerivative) {
  const Matrix3d F = strained_gradient();
  const double pressure = 3e4;
  for (MaterialModel model : kModels) {
    const Constitutive m = material_for(model);
    Matrix3d P, ignored;
    evaluate_material(m, F, pressure, P, nullptr);
    const double h = 1e-6;
    for (int i = 0; i < 9; ++i) {
      Matrix3d plus = F, minus = F;
      plus(i % 3, i / 3) += h;
      minus(i % 3, i / 3) -= h;
      const double numeric = (evaluate_material(m, plus, pressure, ignored, nullptr) -
                              evaluate_material(m, minus, pressure, ignored, nullptr)) /
                             (2 * h);
      EXPECT_NEAR(P(i % 3, i / 3), numeric, 1e-6 * P.norm()) << material_name(model) << " component " << i;
    }
  }
}

TEST(Constitutive, TangentIsTheStresssDerivative) {
  const Matrix3d F = strained_gradient();
  const double pressure = -2e4;
  for (MaterialModel model : kModels) {
    const Constitutive m = material_for(model);
    Matrix3d P;
    Matrix9d A;
    evaluate_material(m, F, pressure, P, &A);
    const double h = 1e-6;
    for (int column = 0; column < 9; ++column) {
      Matrix3d plus = F, minus = F, P_plus, P_minus;
      plus(column % 3, column / 3) += h;
      minus(column % 3, column / 3) -= h;
      evaluate_material(m, plus, pressure, P_plus, nullptr);
      evaluate_material(m, minus, pressure, P_minus, nullptr);
      const Matrix3d numeric = (P_plus - P_minus) / (2 * h);
      for (int row = 0; row < 9; ++row)
        EXPECT_NEAR(A(row, column), numeric(row % 3, row / 3), 1e-6 * A.norm())
            << material_name(model) << " entry " << row << "," << column;
    }
  }
}

TEST(Constitutive, RigidRotationCausesNoStress) {
  const Matrix3d R = Eigen::AngleAxisd(1.3, Eigen::Vector3d(-1, 0.5, 2).normalized()).toRotationMatrix();
  for (MaterialModel model : {MaterialModel::corotational, MaterialModel::stvk, MaterialModel::mooney_rivlin}) {
    Matrix3d P;
    const double energy = evaluate_material(material_for(model), R, 0.0, P, nullptr);
    EXPECT_LT(P.norm(), 1e-9 * 1e6) << material_name(model);
    EXPECT_NEAR(energy, 0.0, 1e-9 * 1e6) << material_name(model);
  }
  // The linear material is not rotation invariant: that is its known flaw.
  Matrix3d P;
  evaluate_material(material_for(MaterialModel::linear), R, 0.0, P, nullptr);
  EXPECT_GT(P.norm(), 1e4);
}

TEST(Constitutive, CorotationalAndStVenantKirchhoffEqualLinearAtSmallStrain) {
  Matrix3d direction;
  direction << 0.3, -0.7, 0.2, 0.5, 0.1, -0.4, 0.9, 0.6, -0.2;
  Matrix3d P_linear, P_other;
  for (MaterialModel model : {MaterialModel::corotational, MaterialModel::stvk}) {
    double previous_gap = 0;
    for (double scale : {1e-2, 1e-3, 1e-4}) {
      const Matrix3d F = Matrix3d::Identity() + scale * direction;
      evaluate_material(material_for(MaterialModel::linear), F, 0.0, P_linear, nullptr);
      evaluate_material(material_for(model), F, 0.0, P_other, nullptr);
      const double gap = (P_other - P_linear).norm() / P_linear.norm();
      EXPECT_LT(gap, 5 * scale) << material_name(model);  // first order in the strain
      if (previous_gap > 0) {
        EXPECT_LT(gap, 0.2 * previous_gap) << material_name(model);
      }
      previous_gap = gap;
    }
  }
}

TEST(Constitutive, MooneyRivlinMatchesLinearShearAndBulkModuliAtSmallStrain) {
  // Small-strain shear modulus 2 (c1 + c2) = μ; bulk response from the pressure p = κ (J − 1).
  const Material m = Material::mooney_rivlin_from_young(1e6, 0.45, 0);
  Matrix3d shear = Matrix3d::Identity();
  shear(0, 1) = 1e-5;
  Matrix3d P;
  evaluate_material(Constitutive(m), shear, 0.0, P, nullptr);
  EXPECT_NEAR(P(0, 1), m.lame_mu() * 1e-5, 1e-4 * m.lame_mu() * 1e-5);
}

TEST(Constitutive, PolarRotationIsARotation) {
  const Matrix3d F = strained_gradient();
  const Matrix3d R = polar_rotation(F);
  EXPECT_NEAR((R.transpose() * R - Matrix3d::Identity()).norm(), 0, 1e-12);
  EXPECT_NEAR(R.determinant(), 1, 1e-12);
  const Matrix3d S = R.transpose() * F;
  EXPECT_NEAR((S - S.transpose()).norm(), 0, 1e-12);
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<Matrix3d>(0.5 * (S + S.transpose())).eigenvalues().minCoeff(), 0);
}

TEST(Constitutive, CorotationalStressInLanesIsEachLanesStress) {
  // Lanes of different rotations and strains: the undeformed, a small strain,
  // the strained and rotated gradient, one compressed to half its volume and
  // one stretched to three times (the cube root's scaling in the iteration).
  const Constitutive m = material_for(MaterialModel::corotational);
  std::array<Matrix3d, kStressLanes> gradients;
  gradients[0] = Matrix3d::Identity();
  gradients[1] = Matrix3d::Identity() + 1e-4 * Matrix3d::Ones();
  gradients[2] = strained_gradient();
  gradients[3] = 0.7937 * strained_gradient();
  gradients[4] = 1.4422 * Eigen::AngleAxisd(2.5, Eigen::Vector3d(0, 1, 0)).toRotationMatrix();
  for (std::size_t l = 5; l < gradients.size(); ++l)
    gradients[l] =
        Eigen::AngleAxisd(0.3 * static_cast<double>(l), Eigen::Vector3d(1, -1, 2).normalized()).toRotationMatrix() *
        (Matrix3d::Identity() + 0.05 * static_cast<double>(l) * Matrix3d::Identity().reverse());
  double F[9][kStressLanes], P[9][kStressLanes];
  for (int l = 0; l < kStressLanes; ++l)
    for (int k = 0; k < 9; ++k) F[k][l] = gradients[static_cast<std::size_t>(l)](k % 3, k / 3);
  corotational_stress_lanes(m, F, P);
  for (int l = 0; l < kStressLanes; ++l) {
    Matrix3d expected, lane;
    evaluate_material(m, gradients[static_cast<std::size_t>(l)], 0.0, expected, nullptr);
    for (int k = 0; k < 9; ++k) lane(k % 3, k / 3) = P[k][l];
    // Both stop the polar iteration within about 1e-14 of the rotation (its
    // own accuracy, from different scales ζ): P's error is that times the moduli.
    EXPECT_LE((lane - expected).norm(), 1e-13 * (2 * m.mu + 3 * m.lambda)) << "lane " << l;
  }
}

}  // namespace
}  // namespace organsim::fem

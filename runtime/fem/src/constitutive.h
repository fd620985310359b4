// Stress and tangent of one P1 tetrahedron's material at a deformation
// gradient F (constant over a linear tetrahedron, so one point integrates
// every term exactly). Matrices over F are indexed by vec(F), column-major:
// entry (i, k) of F is component i + 3k.
#pragma once

#include <Eigen/Core>

#include "organsim/fem/material.h"

namespace organsim::fem {

using Matrix9d = Eigen::Matrix<double, 9, 9>;

/// The material's constants in the form the formulas use.
struct Constitutive {
  MaterialModel model = MaterialModel::linear;
  double mu = 0, lambda = 0;  ///< Lamé constants, Pa (linear, corotational, stvk)
  double c1 = 0, c2 = 0;      ///< Pa (mooney-rivlin)
  double bulk_modulus = 0;    ///< κ, Pa (mooney-rivlin)

  explicit Constitutive(const Material& material);
  Constitutive() = default;
};

/// Energy density W (J/m³), first Piola–Kirchhoff stress P = ∂W/∂F (Pa) and,
/// when `tangent` is given, A = ∂²W/∂F² (Pa) at F. For mooney-rivlin, W
/// includes the pressure terms p (J − 1) − p²/(2κ) of the element's pressure
/// `pressure` (Pa); the other models ignore it. Returns W.
double evaluate_material(const Constitutive& material, const Eigen::Matrix3d& F, double pressure, Eigen::Matrix3d& P,
                         Matrix9d* tangent) noexcept;

/// Rotation R of the polar decomposition F = R S (det F > 0).
Eigen::Matrix3d polar_rotation(const Eigen::Matrix3d& F) noexcept;

/// Tetrahedra per call of corotational_stress_lanes.
constexpr int kStressLanes = 8;
/// The co-rotational stress P of kStressLanes tetrahedra at once (lane l:
/// entry k = i + 3j of F and P at [k][l]; every det F > 0), without the
/// tangent: what a frame's gradient needs, the polar factor's Newton
/// iteration (polar_rotation's, with the same stopping rule per lane) run on
/// all lanes together, in SIMD registers (AVX-512 or AVX2 clones, picked at
/// load). Equal to evaluate_material's P to round-off.
void corotational_stress_lanes(const Constitutive& material, const double (&F)[9][kStressLanes],
                               double (&P)[9][kStressLanes]) noexcept;

}  // namespace organsim::fem

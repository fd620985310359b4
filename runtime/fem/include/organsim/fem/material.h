// Materials of the tetrahedral FEM models (Ogata et al.; docs/fem.md).
//
//   linear         W = μ ε:ε + (λ/2) (tr ε)²,  ε = sym(F − I)       (small strain)
//   corotational   W = μ ‖F − R‖² + (λ/2) (tr(RᵀF) − 3)²,  F = R S (polar)
//                  — its forces are exactly the warped-stiffness forces R K₀ (Rᵀx − X)
//                  of co-rotational FEM; its Hessian is their consistent tangent
//   stvk           W = (λ/2) (tr E)² + μ E:E,  E = ½ (FᵀF − I)     (total Lagrangian)
//   mooney-rivlin  W = c₁ (Ĩ₁ − 3) + c₂ (Ĩ₂ − 3) + p (J − 1) − p²/(2κ),
//                  Ĩ₁ = J^(−2/3) I₁, Ĩ₂ = J^(−4/3) I₂, one pressure p per tetrahedron
//                  (P1/P0, the paper's perturbed Lagrangian, eqs. 1–4), plus the
//                  pressure-jump stabilization (eqs. 5–7) weighted by β.
// λ, μ are the Lamé constants of (E, ν). Units: Pa.
#pragma once

#include <cstdint>
#include <string>

namespace organsim::fem {

enum class MaterialModel : std::uint8_t { linear, corotational, stvk, mooney_rivlin };

/// "linear", "corotational", "stvk" or "mooney-rivlin".
const char* material_name(MaterialModel model) noexcept;
/// Parses a material name; false for an unknown one.
bool parse_material_model(const std::string& name, MaterialModel& model) noexcept;

struct Material {
  MaterialModel model = MaterialModel::linear;
  double young_modulus = 0;  ///< E, Pa (linear, corotational, stvk)
  double poisson_ratio = 0;  ///< ν, in (−1, 0.5) (linear, corotational, stvk)
  double c1 = 0, c2 = 0;     ///< Pa (mooney-rivlin)
  double bulk_modulus = 0;   ///< κ, Pa (mooney-rivlin)
  /// β of the pressure-jump stabilization (mooney-rivlin; 0: none). The jump
  /// across a face of area S shared by tetrahedra e and j is weighted by
  /// β (h_e + h_j) S / κ, h being a tetrahedron's diameter (its longest edge).
  double stabilization = 0;

  double lame_mu() const noexcept;      ///< E / (2 (1 + ν))
  double lame_lambda() const noexcept;  ///< E ν / ((1 + ν)(1 − 2ν))

  /// The paper's conversion for its comparisons: c₁ + c₂ = E / (4 (1 + ν)) split
  /// 1:1, so that the small-strain shear modulus 2 (c₁ + c₂) equals μ, and
  /// κ = E / (3 (1 − 2ν)) (E = 1 MPa, ν = 0.49: c₁ = c₂ = 8.39e4 Pa, κ = 1.667e7 Pa).
  static Material mooney_rivlin_from_young(double young_modulus, double poisson_ratio, double stabilization);
  /// A displacement-only material from (E, ν).
  static Material from_young(MaterialModel model, double young_modulus, double poisson_ratio);
};

}  // namespace organsim::fem

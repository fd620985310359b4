#include "organsim/multibeam/clamped_beam.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

namespace organsim::multibeam {

using Matrix12d = Eigen::Matrix<double, 12, 12>;

BeamElasticity BeamElasticity::from(double young_modulus, double poisson_ratio) noexcept {
  BeamElasticity e;
  e.young_modulus = young_modulus;
  e.shear_modulus = young_modulus / (2.0 * (1.0 + poisson_ratio));
  e.shear_coefficient = 6.0 * (1.0 + poisson_ratio) / (7.0 + 6.0 * poisson_ratio);
  return e;
}

namespace {

// Bending works on generalized per-node variables (d_y, d_z, d'_y, d'_z): the
// transverse displacements and their slopes, d'_y = θz and d'_z = −θy. In those
// variables both bending planes share one Hermite matrix, so a section with
// principal directions p_k and inertias I_k contributes Kh(I_k) ⊗ p_k p_kᵀ.
int bending_dof(int hermite_index, int component, double& sign) {
  const int node = hermite_index / 2;
  sign = 1.0;
  if (hermite_index % 2 == 0) return 6 * node + 1 + component;  // v or w
  if (component == 0) return 6 * node + 5;                      // slope of v = θz
  sign = -1.0;                                                  // slope of w = −θy
  return 6 * node + 4;
}

}  // namespace

Matrix12d element_stiffness(const model::BeamSection& section, double h, const BeamElasticity& elasticity,
                            const BeamBuildOptions& options) noexcept {
  Matrix12d k = Matrix12d::Zero();
  const double e_modulus = elasticity.young_modulus;
  const double axial = e_modulus * section.area / h;
  k(0, 0) = k(6, 6) = axial;
  k(0, 6) = k(6, 0) = -axial;
  const double torsion = elasticity.shear_modulus * section.torsion_j / h;
  k(3, 3) = k(9, 9) = torsion;
  k(3, 9) = k(9, 3) = -torsion;

  Eigen::Matrix2d second_moments;  // [[∫y², ∫yz], [∫yz, ∫z²]]
  second_moments << section.i_zz, section.i_yz, section.i_yz, section.i_yy;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> principal;
  principal.computeDirect(second_moments);
  for (int p = 0; p < 2; ++p) {
    const double inertia = std::max(principal.eigenvalues()[p], 0.0);
    const Eigen::Vector2d direction = principal.eigenvectors().col(p);
    double phi = 0.0;  // Timoshenko's shear parameter 12EI / (κGA h²)
    if (options.theory == BeamTheory::timoshenko && section.area > 0.0)
      phi =
          12.0 * e_modulus * inertia / (elasticity.shear_coefficient * elasticity.shear_modulus * section.area * h * h);
    const double f = e_modulus * inertia / ((1.0 + phi) * h * h * h);
    Eigen::Matrix4d hermite;
    hermite << 12.0, 6.0 * h, -12.0, 6.0 * h,                         //
        6.0 * h, (4.0 + phi) * h * h, -6.0 * h, (2.0 - phi) * h * h,  //
        -12.0, -6.0 * h, 12.0, -6.0 * h,                              //
        6.0 * h, (2.0 - phi) * h * h, -6.0 * h, (4.0 + phi) * h * h;
    hermite *= f;
    for (int a = 0; a < 4; ++a)
      for (int c = 0; c < 2; ++c) {
        double sign_a;
        const int i = bending_dof(a, c, sign_a);
        for (int b = 0; b < 4; ++b)
          for (int d = 0; d < 2; ++d) {
            double sign_b;
            const int j = bending_dof(b, d, sign_b);
            k(i, j) += hermite(a, b) * direction[c] * direction[d] * sign_a * sign_b;
          }
      }
  }

  if (options.centroid_offsets && (section.centroid_y != 0.0 || section.centroid_z != 0.0)) {
    // The element's axis is the centroid line, at offset e from the nodes:
    // u_centroid = u_node + θ × e = u_node + M θ with M = −[e]×. Then
    // K_nodes = Eᵀ K E with E = [[I, M], [0, I]] per node.
    const double ey = section.centroid_y, ez = section.centroid_z;
    Eigen::Matrix3d m;
    m << 0.0, ez, -ey,  //
        -ez, 0.0, 0.0,  //
        ey, 0.0, 0.0;
    for (int node = 0; node < 2; ++node) k.block<12, 3>(0, 6 * node + 3) += k.block<12, 3>(0, 6 * node) * m;
    for (int node = 0; node < 2; ++node) k.block<3, 12>(6 * node + 3, 0) += m.transpose() * k.block<3, 12>(6 * node, 0);
  }
  return k;
}

ClampedBeam::ClampedBeam(std::uint32_t max_elements)
    : capacity_(max_elements),
      diagonal_(max_elements + 1),
      upper_(max_elements + 1),
      carry_(max_elements + 1),
      response_(max_elements + 1) {}

Status ClampedBeam::build(const model::BeamSection* sections, std::uint32_t element_count, double length,
                          const BeamElasticity& elasticity, const BeamBuildOptions& options,
                          const Eigen::Matrix3d* foundation) noexcept {
  built_ = false;
  if (element_count == 0 || element_count > capacity_) return Status::singular_beam;
  if (!std::isfinite(length) || length <= 0.0 || !std::isfinite(elasticity.young_modulus) ||
      !(elasticity.young_modulus > 0.0) || !(elasticity.shear_modulus > 0.0))
    return Status::not_finite;

  double max_area = 0.0, max_inertia = 0.0, max_torsion = 0.0;
  for (std::uint32_t e = 0; e < element_count; ++e) {
    const model::BeamSection& s = sections[e];
    for (double v : {s.area, s.i_yy, s.i_zz, s.i_yz, s.torsion_j, s.centroid_y, s.centroid_z})
      if (!std::isfinite(v)) return Status::not_finite;
    max_area = std::max(max_area, s.area);
    max_inertia = std::max({max_inertia, s.i_yy, s.i_zz});
    max_torsion = std::max(max_torsion, s.torsion_j);
  }
  if (!(max_area > 0.0) || !(max_inertia > 0.0)) return Status::singular_beam;
  constexpr double kFloor = 1e-3;
  if (!(max_torsion > 0.0)) max_torsion = max_inertia;

  const double h = length / element_count;
  for (std::uint32_t n = 1; n <= element_count; ++n) diagonal_[n].setZero();
  for (std::uint32_t e = 0; e < element_count; ++e) {
    model::BeamSection s = sections[e];
    s.area = std::max(s.area, kFloor * max_area);
    s.i_yy = std::max(s.i_yy, kFloor * max_inertia);
    s.i_zz = std::max(s.i_zz, kFloor * max_inertia);
    s.torsion_j = std::max(s.torsion_j, kFloor * max_torsion);
    const double bound = 0.999 * std::sqrt(s.i_yy * s.i_zz);  // keep the section tensor positive definite
    s.i_yz = std::clamp(s.i_yz, -bound, bound);
    const Matrix12d k = element_stiffness(s, h, elasticity, options);
    diagonal_[e + 1] += k.block<6, 6>(6, 6);
    if (e >= 1) {
      diagonal_[e] += k.block<6, 6>(0, 0);
      upper_[e] = k.block<6, 6>(0, 6);
    }
  }
  if (foundation)
    for (std::uint32_t n = 1; n <= element_count; ++n) {
      if (!foundation[n - 1].allFinite()) return Status::not_finite;
      diagonal_[n].topLeftCorner<3, 3>() += foundation[n - 1];
    }

  // Block elimination from the clamp to the tip: S_1 = K_11,
  // S_{n+1} = K_{n+1,n+1} − K_{n,n+1}ᵀ S_n⁻¹ K_{n,n+1}; carry_n = −S_n⁻¹ K_{n,n+1}.
  Matrix6d schur = diagonal_[1];
  for (std::uint32_t n = 1; n < element_count; ++n) {
    const Eigen::LLT<Matrix6d> factor(schur);
    if (factor.info() != Eigen::Success) return Status::singular_beam;
    carry_[n] = -factor.solve(upper_[n]);
    schur = diagonal_[n + 1] + upper_[n].transpose() * carry_[n];
  }
  tip_full_ = schur;
  const Eigen::Matrix3d rotations = schur.block<3, 3>(3, 3);
  const Eigen::LLT<Eigen::Matrix3d> rotation_factor(rotations);
  if (rotation_factor.info() != Eigen::Success) return Status::singular_beam;
  const Eigen::Matrix3d tip_rotation = -rotation_factor.solve(schur.block<3, 3>(3, 0));
  tip_stiffness_ = schur.block<3, 3>(0, 0) + schur.block<3, 3>(0, 3) * tip_rotation;
  if (!tip_stiffness_.allFinite()) return Status::singular_beam;

  response_[element_count].topRows<3>().setIdentity();
  response_[element_count].bottomRows<3>() = tip_rotation;
  for (std::uint32_t n = element_count - 1; n >= 1; --n) response_[n] = carry_[n] * response_[n + 1];
  response_[0].setZero();
  elements_ = element_count;
  length_ = length;
  built_ = true;
  return Status::ok;
}

}  // namespace organsim::multibeam

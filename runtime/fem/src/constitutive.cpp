#include "constitutive.h"

#include <algorithm>
#include <cmath>

#include <Eigen/LU>

namespace organsim::fem {

namespace {

using Eigen::Matrix3d;

double double_dot(const Matrix3d& a, const Matrix3d& b) noexcept { return (a.array() * b.array()).sum(); }

Matrix3d symmetric_part(const Matrix3d& a) noexcept { return 0.5 * (a + a.transpose()); }

/// dF for the vec index `column`: one entry 1, the rest 0.
Matrix3d unit_direction(int column) noexcept {
  Matrix3d d = Matrix3d::Zero();
  d(column % 3, column / 3) = 1;
  return d;
}

template <typename DirectionalDerivative>
void fill_tangent(Matrix9d& tangent, DirectionalDerivative&& dP) noexcept {
  for (int column = 0; column < 9; ++column) {
    const Matrix3d d = dP(unit_direction(column));
    tangent.col(column) = Eigen::Map<const Eigen::Matrix<double, 9, 1>>(d.data());
  }
  // The exact tangent is symmetric; symmetrizing removes round-off asymmetry
  // so that the assembled matrix is exactly symmetric.
  tangent = 0.5 * (tangent + tangent.transpose()).eval();
}

double linear(const Constitutive& m, const Matrix3d& F, Matrix3d& P, Matrix9d* tangent) noexcept {
  const Matrix3d strain = symmetric_part(F - Matrix3d::Identity());
  const double trace = strain.trace();
  P = 2 * m.mu * strain + m.lambda * trace * Matrix3d::Identity();
  if (tangent)
    fill_tangent(*tangent, [&](const Matrix3d& dF) -> Matrix3d {
      return 2 * m.mu * symmetric_part(dF) + m.lambda * dF.trace() * Matrix3d::Identity();
    });
  return m.mu * double_dot(strain, strain) + 0.5 * m.lambda * trace * trace;
}

double stvk(const Constitutive& m, const Matrix3d& F, Matrix3d& P, Matrix9d* tangent) noexcept {
  const Matrix3d E = 0.5 * (F.transpose() * F - Matrix3d::Identity());
  const double trace = E.trace();
  const Matrix3d S = m.lambda * trace * Matrix3d::Identity() + 2 * m.mu * E;
  P = F * S;
  if (tangent)
    fill_tangent(*tangent, [&](const Matrix3d& dF) -> Matrix3d {
      const Matrix3d dE = symmetric_part(F.transpose() * dF);
      const Matrix3d dS = m.lambda * dE.trace() * Matrix3d::Identity() + 2 * m.mu * dE;
      return dF * S + F * dS;
    });
  return 0.5 * m.lambda * trace * trace + m.mu * double_dot(E, E);
}

Eigen::Vector3d axial(const Matrix3d& skew) noexcept { return {skew(2, 1), skew(0, 2), skew(1, 0)}; }

Matrix3d cross_matrix(const Eigen::Vector3d& w) noexcept {
  Matrix3d m;
  m << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return m;
}

double corotational(const Constitutive& m, const Matrix3d& F, Matrix3d& P, Matrix9d* tangent) noexcept {
  const Matrix3d R = polar_rotation(F);
  const Matrix3d S = symmetric_part(R.transpose() * F);
  const double volumetric = S.trace() - 3;
  P = 2 * m.mu * (F - R) + m.lambda * volumetric * R;
  if (tangent) {
    // δR = R [w]×, with (tr S · I − S) w = axial(Rᵀ δF − δFᵀ R) (from Rᵀ δF = [w]× S + δS).
    const Eigen::PartialPivLU<Matrix3d> rotation_rate((S.trace() * Matrix3d::Identity() - S).eval());
    fill_tangent(*tangent, [&](const Matrix3d& dF) -> Matrix3d {
      const Matrix3d RtdF = R.transpose() * dF;
      const Eigen::Vector3d w = rotation_rate.solve(axial(RtdF - RtdF.transpose()));
      const Matrix3d dR = R * cross_matrix(w);
      return 2 * m.mu * (dF - dR) + m.lambda * RtdF.trace() * R + m.lambda * volumetric * dR;
    });
  }
  return m.mu * (F - R).squaredNorm() + 0.5 * m.lambda * volumetric * volumetric;
}

/// What mooney_rivlin's energy, stress and tangent share at one F.
struct MooneyRivlinKinematics {
  double J, I1, I2, a, b;  ///< det F, the invariants of C, J^(−2/3), J^(−4/3)
  Matrix3d G, C, FC;       ///< F⁻ᵀ, FᵀF, F C

  explicit MooneyRivlinKinematics(const Matrix3d& F) noexcept
      : J(F.determinant()), G(F.inverse().transpose()), C(F.transpose() * F), FC(F * C) {
    I1 = C.trace();
    I2 = 0.5 * (I1 * I1 - double_dot(C, C));
    a = std::pow(J, -2.0 / 3.0);
    b = a * a;
  }
};

/// A = ∂P/∂F of mooney_rivlin's P, entry by entry: A(i + 3j, r + 3s) = ∂P_ij/∂F_rs.
/// With G = F⁻ᵀ, B = FFᵀ, H = I₁F − FC and δ for the identity, the derivatives
/// of P's parts in the direction of the unit matrix at (r, s) are
///   ∂J/J = G_rs,  ∂G_ij = −G_is G_rj,  ∂I₁ = 2F_rs,  ∂I₂ = 2H_rs,
///   ∂(FC)_ij = δ_ir C_sj + F_is F_rj + B_ir δ_sj;
/// collected, every term is symmetric under (i, j) ↔ (r, s), so the lower
/// triangle is computed and mirrored (the matrix is exactly symmetric).
void mooney_rivlin_tangent(const Constitutive& m, const Matrix3d& F, const MooneyRivlinKinematics& k, double p,
                           Matrix9d& A) noexcept {
  const Matrix3d& G = k.G;
  const Matrix3d B = F * F.transpose(), H = k.I1 * F - k.FC;
  const double c1a = m.c1 * k.a, c2b = m.c2 * k.b, pJ = p * k.J;
  for (int s = 0; s < 3; ++s)
    for (int r = 0; r < 3; ++r)
      for (int j = s; j < 3; ++j)
        for (int i = j == s ? r : 0; i < 3; ++i) {
          const double identity = i == r && j == s ? 1.0 : 0.0;
          const double cross = G(i, s) * G(r, j), GG = G(r, s) * G(i, j);
          const double first = 2 * identity - (4.0 / 3.0) * (F(r, s) * G(i, j) + G(r, s) * F(i, j)) +
                               (4.0 / 9.0) * k.I1 * GG + (2.0 / 3.0) * k.I1 * cross;
          const double second = 4 * F(r, s) * F(i, j) + 2 * k.I1 * identity - 2 * (i == r ? k.C(s, j) : 0.0) -
                                2 * F(i, s) * F(r, j) - 2 * (j == s ? B(i, r) : 0.0) -
                                (8.0 / 3.0) * (H(r, s) * G(i, j) + G(r, s) * H(i, j)) + (16.0 / 9.0) * k.I2 * GG +
                                (4.0 / 3.0) * k.I2 * cross;
          A(i + 3 * j, r + 3 * s) = A(r + 3 * s, i + 3 * j) = c1a * first + c2b * second + pJ * (GG - cross);
        }
}

double mooney_rivlin(const Constitutive& m, const Matrix3d& F, double p, Matrix3d& P, Matrix9d* tangent) noexcept {
  const MooneyRivlinKinematics k(F);
  // ∂I₁/∂F = 2F, ∂I₂/∂F = 2 (I₁ F − F C), ∂J/∂F = J F⁻ᵀ.
  const Matrix3d dW1 = 2 * F - (2.0 / 3.0) * k.I1 * k.G;
  const Matrix3d dW2 = 2 * (k.I1 * F - k.FC) - (4.0 / 3.0) * k.I2 * k.G;
  P = m.c1 * k.a * dW1 + m.c2 * k.b * dW2 + p * k.J * k.G;
  if (tangent) mooney_rivlin_tangent(m, F, k, p, *tangent);
  return m.c1 * (k.a * k.I1 - 3) + m.c2 * (k.b * k.I2 - 3) + p * (k.J - 1) - p * p / (2 * m.bulk_modulus);
}

}  // namespace

Constitutive::Constitutive(const Material& material)
    : model(material.model),
      mu(material.lame_mu()),
      lambda(material.lame_lambda()),
      c1(material.c1),
      c2(material.c2),
      bulk_modulus(material.bulk_modulus) {}

Matrix3d polar_rotation(const Matrix3d& F) noexcept {
  // Newton's iteration for the orthogonal polar factor with determinant
  // scaling (Higham 1986), R ← ½ (ζ R + R⁻ᵀ/ζ), ζ = |det R|^(−1/3): quadratic
  // convergence to the rotation when det F > 0, in a handful of 3×3 inversions
  // (an SVD costs several times more; the co-rotational forces need one per
  // tetrahedron and frame). Once quadratic, an iterate's distance to the
  // rotation is about half the square of the step that made it: a step under
  // 1e-7 leaves it within 1e-14, so the iteration stops there rather than
  // take one more step to see it change by nothing. Within 1e-3 of det R = 1
  // the scale is within 4e-4 of 1, the unscaled step converges as fast, and
  // the cube root (a quarter of the co-rotational gradient's time) is skipped.
  Matrix3d R = F;
  for (int iteration = 0; iteration < 30; ++iteration) {
    const double determinant = R.determinant();
    const double zeta = std::abs(std::abs(determinant) - 1.0) < 1e-3 ? 1.0 : std::cbrt(1.0 / std::abs(determinant));
    const Matrix3d next = 0.5 * (zeta * R + R.inverse().transpose() / zeta);
    const double change = (next - R).cwiseAbs().maxCoeff();
    R = next;
    if (change < 1e-7) break;
  }
  return R;
}

#if defined(__GNUC__) && defined(__x86_64__) && !defined(__AVX512F__)
__attribute__((target_clones("arch=x86-64-v4", "arch=x86-64-v3", "default")))
#endif
void corotational_stress_lanes(const Constitutive& m, const double (&F)[9][kStressLanes],
                               double (&P)[9][kStressLanes]) noexcept {
  constexpr int L = kStressLanes;
  // polar_rotation's iteration, lane by lane in each step: R ← ½ (ζ R + C/(ζ det R)),
  // C R's cofactor matrix (R⁻ᵀ = C / det R); a lane stops changing once its
  // step is under 1e-7.
  double R[9][L], C[9][L], det[L], zeta[L], change[L];
  bool active[L];
  for (int k = 0; k < 9; ++k)
    for (int l = 0; l < L; ++l) R[k][l] = F[k][l];
  for (int l = 0; l < L; ++l) active[l] = true;
  for (int iteration = 0; iteration < 30; ++iteration) {
    for (int l = 0; l < L; ++l) {
      const double r00 = R[0][l], r10 = R[1][l], r20 = R[2][l], r01 = R[3][l], r11 = R[4][l], r21 = R[5][l],
                   r02 = R[6][l], r12 = R[7][l], r22 = R[8][l];
      C[0][l] = r11 * r22 - r12 * r21;
      C[3][l] = r12 * r20 - r10 * r22;
      C[6][l] = r10 * r21 - r11 * r20;
      C[1][l] = r02 * r21 - r01 * r22;
      C[4][l] = r00 * r22 - r02 * r20;
      C[7][l] = r01 * r20 - r00 * r21;
      C[2][l] = r01 * r12 - r02 * r11;
      C[5][l] = r02 * r10 - r00 * r12;
      C[8][l] = r00 * r11 - r01 * r10;
      det[l] = r00 * C[0][l] + r01 * C[3][l] + r02 * C[6][l];
      // The scale need not be exact (any ζ > 0 keeps the iteration's fixed
      // point): near det R = 1 the series of |det R|^(−1/3) to second order
      // (within 0.2 % for |det R| within 20 % of 1), in the lanes; the cube
      // root only farther off, one lane at a time.
      const double off = std::abs(det[l]) - 1.0;
      zeta[l] = 1.0 - off / 3.0 + (2.0 / 9.0) * off * off;
    }
    for (int l = 0; l < L; ++l)
      if (!(std::abs(std::abs(det[l]) - 1.0) < 0.2)) zeta[l] = std::cbrt(1.0 / std::abs(det[l]));
    double half_zeta[L], half_inverse[L];  // one division per lane, not nine
    for (int l = 0; l < L; ++l) {
      change[l] = 0.0;
      half_zeta[l] = 0.5 * zeta[l];
      half_inverse[l] = 0.5 / (det[l] * zeta[l]);
    }
    for (int k = 0; k < 9; ++k)
      for (int l = 0; l < L; ++l) {
        const double next = half_zeta[l] * R[k][l] + half_inverse[l] * C[k][l];
        change[l] = std::max(change[l], std::abs(next - R[k][l]));
        R[k][l] = active[l] ? next : R[k][l];
      }
    bool any = false;
    for (int l = 0; l < L; ++l) {
      active[l] = active[l] && !(change[l] < 1e-7);
      any = any || active[l];
    }
    if (!any) break;
  }
  // P = 2μ (F − R) + λ (tr(Rᵀ F) − 3) R.
  double volumetric[L];
  for (int l = 0; l < L; ++l) volumetric[l] = -3.0;
  for (int k = 0; k < 9; ++k)
    for (int l = 0; l < L; ++l) volumetric[l] += R[k][l] * F[k][l];
  for (int k = 0; k < 9; ++k)
    for (int l = 0; l < L; ++l) P[k][l] = 2 * m.mu * (F[k][l] - R[k][l]) + m.lambda * volumetric[l] * R[k][l];
}

double evaluate_material(const Constitutive& material, const Matrix3d& F, double pressure, Matrix3d& P,
                         Matrix9d* tangent) noexcept {
  switch (material.model) {
    case MaterialModel::linear: return linear(material, F, P, tangent);
    case MaterialModel::corotational: return corotational(material, F, P, tangent);
    case MaterialModel::stvk: return stvk(material, F, P, tangent);
    case MaterialModel::mooney_rivlin: return mooney_rivlin(material, F, pressure, P, tangent);
  }
  return 0;
}

}  // namespace organsim::fem

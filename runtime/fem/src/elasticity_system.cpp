#include "organsim/fem/elasticity_system.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include "constitutive.h"

namespace organsim::fem {

namespace {

constexpr std::int32_t kNoEntry = std::numeric_limits<std::int32_t>::min();

/// Faces of a tetrahedron (a, b, c, d), as the node triples opposite each corner.
constexpr int kFaceCorners[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};

double triangle_area(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) noexcept {
  return 0.5 * (b - a).cross(c - a).norm();
}

}  // namespace

ElasticitySystem::ElasticitySystem(const TetMesh& mesh, const Material& material, const std::vector<bool>& constrained)
    : mesh_(mesh), material_(material) {
  const std::size_t nodes = mesh_.nodes.size(), tets = mesh_.tetrahedra.size();
  if (constrained.size() != 3 * nodes)
    throw std::invalid_argument("ElasticitySystem: the constraint mask must have 3 entries per node");
  local_size_ = has_pressure() ? 13 : 12;
  const std::size_t dofs = 3 * nodes + (has_pressure() ? tets : 0);
  free_of_.resize(dofs);
  for (std::size_t d = 0; d < dofs; ++d) {
    if (d < constrained.size() && constrained[d])
      free_of_[d] = -1 - static_cast<std::int32_t>(constrained_count_++);
    else
      free_of_[d] = static_cast<std::int32_t>(free_count_++);
  }

  volume_.resize(tets);
  gradients_.resize(tets);
  std::vector<double> diameter(tets);
  double diameter_sum = 0;
  for (std::size_t e = 0; e < tets; ++e) {
    const Tetrahedron& t = mesh_.tetrahedra[e];
    for (std::int32_t n : t)
      if (n < 0 || static_cast<std::size_t>(n) >= nodes)
        throw std::invalid_argument("tetrahedra[" + std::to_string(e) + "]: node " + std::to_string(n) +
                                    " does not exist");
    const auto x = [&](int corner) -> const Eigen::Vector3d& {
      return mesh_.nodes[static_cast<std::size_t>(t[corner])];
    };
    Eigen::Matrix3d edges;
    edges << x(1) - x(0), x(2) - x(0), x(3) - x(0);
    volume_[e] = edges.determinant() / 6;
    double longest = 0;
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) longest = std::max(longest, (x(a) - x(b)).norm());
    if (!(volume_[e] > 1e-12 * longest * longest * longest))
      throw std::invalid_argument("tetrahedra[" + std::to_string(e) + "]: " +
                                  (volume_[e] < 0 ? "negative volume: order its nodes so that (b − a, c − a, d − a) is "
                                                    "right-handed"
                                                  : "zero volume (its nodes are coplanar)"));
    diameter[e] = longest;
    diameter_sum += longest;
    // ξ = edges⁻¹ (x − x₀): the rows of edges⁻¹ are ∇N₁..₃; ∇N₀ = −Σ.
    const Eigen::Matrix3d inverse = edges.inverse();
    gradients_[e].row(0) = -inverse.colwise().sum();
    gradients_[e].bottomRows<3>() = inverse;
  }
  mean_diameter_ = tets ? diameter_sum / static_cast<double>(tets) : 0;

  if (has_pressure() && material_.stabilization > 0) {
    struct FaceOwner {
      std::array<std::int32_t, 3> nodes;
      std::int32_t tet;
    };
    std::vector<FaceOwner> faces;
    faces.reserve(4 * tets);
    for (std::size_t e = 0; e < tets; ++e)
      for (const auto& corners : kFaceCorners) {
        std::array<std::int32_t, 3> key = {mesh_.tetrahedra[e][static_cast<std::size_t>(corners[0])],
                                           mesh_.tetrahedra[e][static_cast<std::size_t>(corners[1])],
                                           mesh_.tetrahedra[e][static_cast<std::size_t>(corners[2])]};
        std::sort(key.begin(), key.end());
        faces.push_back({key, static_cast<std::int32_t>(e)});
      }
    std::sort(faces.begin(), faces.end(), [](const FaceOwner& a, const FaceOwner& b) {
      return a.nodes != b.nodes ? a.nodes < b.nodes : a.tet < b.tet;
    });
    for (std::size_t i = 0; i + 1 < faces.size(); ++i) {
      if (faces[i].nodes != faces[i + 1].nodes) continue;
      const auto& n = faces[i].nodes;
      const double area =
          triangle_area(mesh_.nodes[static_cast<std::size_t>(n[0])], mesh_.nodes[static_cast<std::size_t>(n[1])],
                        mesh_.nodes[static_cast<std::size_t>(n[2])]);
      const std::int32_t e = faces[i].tet, j = faces[i + 1].tet;
      const double h = diameter[static_cast<std::size_t>(e)] + diameter[static_cast<std::size_t>(j)];
      jump_faces_.push_back({e, j, material_.stabilization * h * area / material_.bulk_modulus});
      ++i;
    }
  }
  build_pattern();
}

std::int32_t ElasticitySystem::local_dof(std::size_t tet, int local) const noexcept {
  if (local == 12) return static_cast<std::int32_t>(3 * mesh_.nodes.size() + tet);
  return 3 * mesh_.tetrahedra[tet][static_cast<std::size_t>(local / 3)] + local % 3;
}

void ElasticitySystem::build_pattern() {
  using Triplet = Eigen::Triplet<double, int>;
  std::vector<Triplet> free_entries, coupling_entries;
  const auto visit = [&](std::int32_t row_dof, std::int32_t column_dof) {
    const std::int32_t r = free_of_[static_cast<std::size_t>(row_dof)];
    const std::int32_t c = free_of_[static_cast<std::size_t>(column_dof)];
    if (r < 0) return;
    if (c >= 0)
      free_entries.emplace_back(r, c, 0.0);
    else
      coupling_entries.emplace_back(r, -1 - c, 0.0);
  };
  const std::size_t tets = mesh_.tetrahedra.size();
  for (std::size_t e = 0; e < tets; ++e)
    for (int p = 0; p < local_size_; ++p)
      for (int q = 0; q < local_size_; ++q) visit(local_dof(e, p), local_dof(e, q));
  const std::int32_t pressure0 = static_cast<std::int32_t>(3 * mesh_.nodes.size());
  for (const JumpFace& f : jump_faces_)
    for (std::int32_t a : {f.first, f.second})
      for (std::int32_t b : {f.first, f.second}) visit(pressure0 + a, pressure0 + b);

  free_free_.resize(free_count_, free_count_);
  free_free_.setFromTriplets(free_entries.begin(), free_entries.end());
  free_constrained_.resize(free_count_, constrained_count_);
  free_constrained_.setFromTriplets(coupling_entries.begin(), coupling_entries.end());

  const auto offset_of = [&](std::int32_t row_dof, std::int32_t column_dof) -> std::int32_t {
    const std::int32_t r = free_of_[static_cast<std::size_t>(row_dof)];
    const std::int32_t c = free_of_[static_cast<std::size_t>(column_dof)];
    if (r < 0) return kNoEntry;
    const SparseMatrix& m = c >= 0 ? free_free_ : free_constrained_;
    const int column = c >= 0 ? c : -1 - c;
    const int* begin = m.innerIndexPtr() + m.outerIndexPtr()[column];
    const int* end = m.innerIndexPtr() + m.outerIndexPtr()[column + 1];
    const auto offset = static_cast<std::int32_t>(std::lower_bound(begin, end, r) - m.innerIndexPtr());
    return c >= 0 ? offset : -1 - offset;
  };
  element_offsets_.resize(tets * static_cast<std::size_t>(local_size_ * local_size_));
  std::size_t k = 0;
  for (std::size_t e = 0; e < tets; ++e)
    for (int q = 0; q < local_size_; ++q)
      for (int p = 0; p < local_size_; ++p) element_offsets_[k++] = offset_of(local_dof(e, p), local_dof(e, q));
  face_offsets_.clear();
  for (const JumpFace& f : jump_faces_)
    for (std::int32_t b : {f.first, f.second})
      for (std::int32_t a : {f.first, f.second}) face_offsets_.push_back(offset_of(pressure0 + a, pressure0 + b));
}

Eigen::Matrix3d ElasticitySystem::deformation_gradient(const Eigen::VectorXd& x, std::size_t tet) const noexcept {
  Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
  for (int a = 0; a < 4; ++a)
    F.noalias() += x.segment<3>(3 * mesh_.tetrahedra[tet][static_cast<std::size_t>(a)]) * gradients_[tet].row(a);
  return F;
}

std::int64_t ElasticitySystem::first_inverted(const Eigen::VectorXd& x) const noexcept {
  if (material_.model == MaterialModel::linear) return -1;
  for (std::size_t e = 0; e < mesh_.tetrahedra.size(); ++e)
    if (!(deformation_gradient(x, e).determinant() > 0)) return static_cast<std::int64_t>(e);
  return -1;
}

void ElasticitySystem::set_foundation(std::vector<FoundationSpring> springs) {
  std::vector<std::array<std::int32_t, 9>> offsets;
  for (std::size_t i = 0; i < springs.size(); ++i) {
    const FoundationSpring& s = springs[i];
    if (s.node < 0 || static_cast<std::size_t>(s.node) >= mesh_.nodes.size())
      throw std::invalid_argument("foundation[" + std::to_string(i) + "]: node out of range");
    if (!(std::isfinite(s.stiffness) && s.stiffness > 0))
      throw std::invalid_argument("foundation[" + std::to_string(i) + "]: the stiffness must be finite and > 0 (N/m)");
    if (s.unilateral && !(s.normal.allFinite() && std::abs(s.normal.norm() - 1.0) < 1e-9))
      throw std::invalid_argument("foundation[" + std::to_string(i) + "]: the normal must be a unit vector");
    std::array<std::int32_t, 9> block{};
    for (int column = 0; column < 3; ++column)
      for (int row = 0; row < 3; ++row) {
        const std::int32_t r = free_of_[static_cast<std::size_t>(3 * s.node + row)];
        const std::int32_t c = free_of_[static_cast<std::size_t>(3 * s.node + column)];
        std::int32_t offset = kNoEntry;
        if (r >= 0 && c >= 0) {
          const int* begin = free_free_.innerIndexPtr() + free_free_.outerIndexPtr()[c];
          const int* end = free_free_.innerIndexPtr() + free_free_.outerIndexPtr()[c + 1];
          offset = static_cast<std::int32_t>(std::lower_bound(begin, end, r) - free_free_.innerIndexPtr());
        } else if (r >= 0) {
          const int column_c = -1 - c;
          const int* begin = free_constrained_.innerIndexPtr() + free_constrained_.outerIndexPtr()[column_c];
          const int* end = free_constrained_.innerIndexPtr() + free_constrained_.outerIndexPtr()[column_c + 1];
          offset = -1 - static_cast<std::int32_t>(std::lower_bound(begin, end, r) - free_constrained_.innerIndexPtr());
        }
        block[static_cast<std::size_t>(3 * column + row)] = offset;
      }
    offsets.push_back(block);
  }
  foundation_ = std::move(springs);
  foundation_offsets_ = std::move(offsets);
}

std::int64_t ElasticitySystem::assemble(const Eigen::VectorXd& x, Eigen::VectorXd& gradient, bool tangent) noexcept {
  const std::int64_t inverted = assemble_body(x, gradient, tangent);
  if (inverted < 0) add_foundation(x, gradient, tangent);
  return inverted;
}

void ElasticitySystem::add_foundation(const Eigen::VectorXd& x, Eigen::VectorXd& gradient, bool tangent) noexcept {
  double* const free_values = free_free_.valuePtr();
  double* const coupling_values = free_constrained_.valuePtr();
  for (std::size_t i = 0; i < foundation_.size(); ++i) {
    const FoundationSpring& s = foundation_[i];
    const Eigen::Vector3d u = x.segment<3>(3 * s.node);
    Eigen::Matrix3d stiffness;
    if (s.unilateral) {
      // Pressed into the support (u·n > 0) it pushes back; at rest and
      // moving away it does not. The tangent keeps the spring at rest, so
      // that a tangent made there holds the body where it lies.
      const double into = u.dot(s.normal);
      if (into > 0) gradient.segment<3>(3 * s.node) += s.stiffness * into * s.normal;
      stiffness = into >= 0 ? Eigen::Matrix3d(s.stiffness * s.normal * s.normal.transpose()) : Eigen::Matrix3d::Zero();
    } else {
      gradient.segment<3>(3 * s.node) += s.stiffness * u;
      stiffness = s.stiffness * Eigen::Matrix3d::Identity();
    }
    if (!tangent) continue;
    for (int k = 0; k < 9; ++k) {
      const std::int32_t offset = foundation_offsets_[i][static_cast<std::size_t>(k)];
      const double value = stiffness(k % 3, k / 3);
      if (offset >= 0)
        free_values[offset] += value;
      else if (offset != kNoEntry)
        coupling_values[-1 - offset] += value;
    }
  }
}

std::int64_t ElasticitySystem::assemble_body(const Eigen::VectorXd& x, Eigen::VectorXd& gradient,
                                             bool tangent) noexcept {
  const Constitutive constitutive(material_);
  const bool nonlinear = material_.model != MaterialModel::linear;
  const std::size_t nodes = mesh_.nodes.size(), tets = mesh_.tetrahedra.size();
  gradient.setZero();
  double* const free_values = free_free_.valuePtr();
  double* const coupling_values = free_constrained_.valuePtr();
  if (tangent) {
    std::fill_n(free_values, free_free_.nonZeros(), 0.0);
    std::fill_n(coupling_values, free_constrained_.nonZeros(), 0.0);
  }
  const auto scatter = [&](std::int32_t offset, double value) {
    if (offset >= 0)
      free_values[offset] += value;
    else if (offset != kNoEntry)
      coupling_values[-1 - offset] += value;
  };

  if (!tangent && material_.model == MaterialModel::corotational) return corotational_gradient(x, gradient);

  Eigen::Matrix3d P;
  Matrix9d A;
  Eigen::Matrix<double, 13, 13> K;
  for (std::size_t e = 0; e < tets; ++e) {
    const Eigen::Matrix3d F = deformation_gradient(x, e);
    const double J = F.determinant();
    if (nonlinear && !(J > 0)) return static_cast<std::int64_t>(e);
    const double pressure = has_pressure() ? x[static_cast<Eigen::Index>(3 * nodes + e)] : 0.0;
    evaluate_material(constitutive, F, pressure, P, tangent ? &A : nullptr);
    if (tangent && definite_tangent_) {
      const Eigen::SelfAdjointEigenSolver<Matrix9d> eigen(A);
      A = eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).asDiagonal() * eigen.eigenvectors().transpose();
    }
    const double V = volume_[e];
    const Eigen::Matrix<double, 4, 3>& g = gradients_[e];
    const Eigen::Matrix<double, 3, 4> forces = V * P * g.transpose();  // column a: ∂Π/∂u_a
    for (int a = 0; a < 4; ++a)
      gradient.segment<3>(3 * mesh_.tetrahedra[e][static_cast<std::size_t>(a)]) += forces.col(a);
    if (has_pressure())
      gradient[static_cast<Eigen::Index>(3 * nodes + e)] += V * (J - 1 - pressure / material_.bulk_modulus);
    if (!tangent) continue;

    // K_ab(i, j) = V Σ_kl A(i + 3k, j + 3l) g_a(k) g_b(l); A is symmetric, so K_ba = K_abᵀ.
    for (int a = 0; a < 4; ++a) {
      Eigen::Matrix<double, 3, 9> contracted = Eigen::Matrix<double, 3, 9>::Zero();  // Σ_k g_a(k) A(i + 3k, ·)
      for (int k = 0; k < 3; ++k) contracted += g(a, k) * A.middleRows<3>(3 * k);
      for (int b = a; b < 4; ++b) {
        Eigen::Matrix3d block = Eigen::Matrix3d::Zero();
        for (int l = 0; l < 3; ++l) block += g(b, l) * contracted.middleCols<3>(3 * l);
        K.block<3, 3>(3 * a, 3 * b) = V * block;
        if (b != a) K.block<3, 3>(3 * b, 3 * a) = V * block.transpose();
      }
    }
    if (has_pressure()) {
      const Eigen::Matrix<double, 3, 4> coupling = V * J * F.inverse().transpose() * g.transpose();  // ∂²Π/∂u_a∂p
      for (int a = 0; a < 4; ++a) {
        K.block<3, 1>(3 * a, 12) = coupling.col(a);
        K.block<1, 3>(12, 3 * a) = coupling.col(a).transpose();
      }
      K(12, 12) = -V / material_.bulk_modulus;
    }
    const std::int32_t* offsets = element_offsets_.data() + e * static_cast<std::size_t>(local_size_ * local_size_);
    for (int q = 0; q < local_size_; ++q)
      for (int p = 0; p < local_size_; ++p) scatter(*offsets++, K(p, q));
  }

  const Eigen::Index pressure0 = static_cast<Eigen::Index>(3 * nodes);
  const std::int32_t* offsets = face_offsets_.data();
  for (const JumpFace& f : jump_faces_) {
    const double jump = x[pressure0 + f.first] - x[pressure0 + f.second];
    gradient[pressure0 + f.first] -= f.weight * jump;
    gradient[pressure0 + f.second] += f.weight * jump;
    if (!tangent) continue;
    scatter(offsets[0], -f.weight);
    scatter(offsets[1], f.weight);
    scatter(offsets[2], f.weight);
    scatter(offsets[3], -f.weight);
    offsets += 4;
  }
  return -1;
}

std::int64_t ElasticitySystem::corotational_gradient(const Eigen::VectorXd& x,
                                                     Eigen::VectorXd& gradient) const noexcept {
  // The stresses kStressLanes tetrahedra at a time (corotational_stress_lanes);
  // a short last block is filled with undeformed ones.
  const Constitutive constitutive(material_);
  const std::size_t tets = mesh_.tetrahedra.size();
  double F[9][kStressLanes], P[9][kStressLanes];
  for (std::size_t first = 0; first < tets; first += kStressLanes) {
    const std::size_t count = std::min<std::size_t>(kStressLanes, tets - first);
    for (std::size_t l = 0; l < static_cast<std::size_t>(kStressLanes); ++l) {
      const Eigen::Matrix3d f = l < count ? deformation_gradient(x, first + l) : Eigen::Matrix3d::Identity();
      if (!(f.determinant() > 0)) return static_cast<std::int64_t>(first + l);
      for (int k = 0; k < 9; ++k) F[k][l] = f(k % 3, k / 3);
    }
    corotational_stress_lanes(constitutive, F, P);
    for (std::size_t l = 0; l < count; ++l) {
      const std::size_t e = first + l;
      Eigen::Matrix3d stress;
      for (int k = 0; k < 9; ++k) stress(k % 3, k / 3) = P[k][l];
      const Eigen::Matrix<double, 3, 4> forces = volume_[e] * stress * gradients_[e].transpose();  // column a: ∂Π/∂u_a
      for (int a = 0; a < 4; ++a)
        gradient.segment<3>(3 * mesh_.tetrahedra[e][static_cast<std::size_t>(a)]) += forces.col(a);
    }
  }
  return -1;
}

double ElasticitySystem::energy(const Eigen::VectorXd& x) const noexcept {
  const Constitutive constitutive(material_);
  const std::size_t nodes = mesh_.nodes.size();
  Eigen::Matrix3d P;
  double total = 0;
  for (std::size_t e = 0; e < mesh_.tetrahedra.size(); ++e) {
    const Eigen::Matrix3d F = deformation_gradient(x, e);
    if (material_.model != MaterialModel::linear && !(F.determinant() > 0))
      return std::numeric_limits<double>::quiet_NaN();
    const double pressure = has_pressure() ? x[static_cast<Eigen::Index>(3 * nodes + e)] : 0.0;
    total += volume_[e] * evaluate_material(constitutive, F, pressure, P, nullptr);
  }
  const Eigen::Index pressure0 = static_cast<Eigen::Index>(3 * nodes);
  for (const JumpFace& f : jump_faces_) {
    const double jump = x[pressure0 + f.first] - x[pressure0 + f.second];
    total -= 0.5 * f.weight * jump * jump;
  }
  for (const FoundationSpring& s : foundation_) {
    const Eigen::Vector3d u = x.segment<3>(3 * s.node);
    const double stretch = s.unilateral ? std::max(u.dot(s.normal), 0.0) : u.norm();
    total += 0.5 * s.stiffness * stretch * stretch;
  }
  return total;
}

Eigen::VectorXd ElasticitySystem::body_force(double density, const Eigen::Vector3d& gravity) const {
  Eigen::VectorXd f = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(3 * mesh_.nodes.size()));
  for (std::size_t e = 0; e < mesh_.tetrahedra.size(); ++e)
    for (std::int32_t n : mesh_.tetrahedra[e]) f.segment<3>(3 * n) += density * volume_[e] / 4 * gravity;
  return f;
}

Eigen::Matrix3d ElasticitySystem::cauchy_stress(const Eigen::VectorXd& x, std::size_t tet) const noexcept {
  const Eigen::Matrix3d F = deformation_gradient(x, tet);
  const double pressure = has_pressure() ? x[static_cast<Eigen::Index>(3 * mesh_.nodes.size() + tet)] : 0.0;
  Eigen::Matrix3d P;
  evaluate_material(Constitutive(material_), F, pressure, P, nullptr);
  if (material_.model == MaterialModel::linear) return P;
  return P * F.transpose() / F.determinant();
}

}  // namespace organsim::fem

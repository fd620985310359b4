#include "stiffness_warping_peer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <stdexcept>

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/LU>
#include <Eigen/SVD>

namespace organsim::bench {
namespace {

Eigen::Matrix3d edges(const std::array<Eigen::Vector3d, 4>& x) {
  Eigen::Matrix3d d;
  d << x[1] - x[0], x[2] - x[0], x[3] - x[0];
  return d;
}

/// The rotation of F's polar decomposition (a proper rotation).
Eigen::Matrix3d rotation_of(const Eigen::Matrix3d& f) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(f, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d u = svd.matrixU();
  if ((u * svd.matrixV().transpose()).determinant() < 0.0) u.col(2) = -u.col(2);
  return u * svd.matrixV().transpose();
}

}  // namespace

StiffnessWarpingPeer::StiffnessWarpingPeer(const fem::TetMesh& mesh, const std::vector<bool>& clamped,
                                           const PeerOptions& options)
    : mesh_(mesh), options_(options) {
  const std::size_t dofs = 3 * mesh.nodes.size();
  if (clamped.size() != dofs) throw std::invalid_argument("one clamp flag per dof");
  free_index_.assign(dofs, -1);
  for (std::size_t d = 0; d < dofs; ++d)
    if (!clamped[d]) {
      free_index_[d] = static_cast<std::int32_t>(free_dofs_.size());
      free_dofs_.push_back(static_cast<std::int32_t>(d));
    }
  const double young = options.young_modulus, nu = options.poisson_ratio;
  const double lambda = young * nu / ((1 + nu) * (1 - 2 * nu)), mu = young / (2 * (1 + nu));
  mass_ = Eigen::VectorXd::Zero(free_count());
  std::vector<Eigen::Triplet<double>> pattern;
  for (const auto& t : mesh.tetrahedra) {
    std::array<Eigen::Vector3d, 4> x;
    for (int i = 0; i < 4; ++i) x[i] = mesh.nodes[static_cast<std::size_t>(t[i])];
    const Eigen::Matrix3d inverse = edges(x).inverse();
    const double volume = std::abs(edges(x).determinant()) / 6.0;
    rest_inverse_.push_back(inverse);
    // Shape function gradients: rows of Dm⁻¹ for nodes 1–3, node 0 their negative sum.
    std::array<Eigen::Vector3d, 4> g;
    for (int i = 1; i < 4; ++i) g[i] = inverse.row(i - 1).transpose();
    g[0] = -(g[1] + g[2] + g[3]);
    Eigen::Matrix<double, 12, 12> k;
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b)
        k.block<3, 3>(3 * a, 3 * b) = volume * (lambda * g[a] * g[b].transpose() + mu * g[b] * g[a].transpose() +
                                                mu * g[a].dot(g[b]) * Eigen::Matrix3d::Identity());
    element_stiffness_.push_back(k);
    for (int a = 0; a < 4; ++a)
      for (int i = 0; i < 3; ++i) {
        const std::int32_t row = free_index_[static_cast<std::size_t>(3 * t[a] + i)];
        if (row < 0) continue;
        mass_[row] += options.density * volume / 4.0;
        for (int b = 0; b < 4; ++b)
          for (int j = 0; j < 3; ++j)
            if (const std::int32_t col = free_index_[static_cast<std::size_t>(3 * t[b] + j)]; col >= 0)
              pattern.emplace_back(row, col, 0.0);
      }
  }
  stiffness_.resize(free_count(), free_count());
  stiffness_.setFromTriplets(pattern.begin(), pattern.end());
  stiffness_.makeCompressed();
  // Where each element entry lands among the values (found once, as Vega does).
  value_of_.assign(144 * mesh.tetrahedra.size(), -1);
  for (std::size_t e = 0; e < mesh.tetrahedra.size(); ++e) {
    const auto& t = mesh.tetrahedra[e];
    for (int r = 0; r < 12; ++r)
      for (int c = 0; c < 12; ++c) {
        const std::int32_t row = free_index_[static_cast<std::size_t>(3 * t[r / 3] + r % 3)];
        const std::int32_t col = free_index_[static_cast<std::size_t>(3 * t[c / 3] + c % 3)];
        if (row < 0 || col < 0) continue;
        const int* begin = stiffness_.innerIndexPtr() + stiffness_.outerIndexPtr()[col];
        const int* end = stiffness_.innerIndexPtr() + stiffness_.outerIndexPtr()[col + 1];
        value_of_[144 * e + static_cast<std::size_t>(12 * r + c)] =
            static_cast<std::int32_t>(std::lower_bound(begin, end, row) - stiffness_.innerIndexPtr());
      }
  }
  system_ = stiffness_;
  internal_.resize(static_cast<Eigen::Index>(dofs));
}

void StiffnessWarpingPeer::assemble(const Eigen::VectorXd& q) {
  internal_.setZero();
  double* values = stiffness_.valuePtr();
  std::fill(values, values + stiffness_.nonZeros(), 0.0);
  for (std::size_t e = 0; e < mesh_.tetrahedra.size(); ++e) {
    const auto& t = mesh_.tetrahedra[e];
    std::array<Eigen::Vector3d, 4> x;
    Eigen::Matrix<double, 12, 1> rest, deformed;
    for (int i = 0; i < 4; ++i) {
      const Eigen::Vector3d& at = mesh_.nodes[static_cast<std::size_t>(t[i])];
      x[i] = at + q.segment<3>(3 * t[i]);
      rest.segment<3>(3 * i) = at;
    }
    const Eigen::Matrix3d r = rotation_of(edges(x) * rest_inverse_[e]);
    for (int i = 0; i < 4; ++i) deformed.segment<3>(3 * i) = r.transpose() * x[i];
    const Eigen::Matrix<double, 12, 12>& k = element_stiffness_[e];
    const Eigen::Matrix<double, 12, 1> local = k * (deformed - rest);
    Eigen::Matrix<double, 12, 12> warped;
    for (int a = 0; a < 4; ++a) {
      internal_.segment<3>(3 * t[a]) += r * local.segment<3>(3 * a);
      for (int b = 0; b < 4; ++b) warped.block<3, 3>(3 * a, 3 * b) = r * k.block<3, 3>(3 * a, 3 * b) * r.transpose();
    }
    for (int entry = 0; entry < 144; ++entry)
      if (const std::int32_t at = value_of_[144 * e + static_cast<std::size_t>(entry)]; at >= 0)
        values[at] += warped(entry / 12, entry % 12);
  }
}

int StiffnessWarpingPeer::step(Eigen::VectorXd& q, Eigen::VectorXd& v, const Eigen::VectorXd& external) {
  assemble(q);
  const double h = options_.time_step, a = options_.mass_damping, b = options_.stiffness_damping;
  // (M + h C + h² K) Δv = h (f_ext − f(q) − C v − h K v), C = a M + b K.
  Eigen::VectorXd free_v(free_count()), rhs(free_count());
  for (Eigen::Index j = 0; j < free_count(); ++j) {
    const auto d = static_cast<Eigen::Index>(free_dofs_[static_cast<std::size_t>(j)]);
    free_v[j] = v[d];
    rhs[j] = external[d] - internal_[d] - a * mass_[j] * v[d];
  }
  rhs -= (b + h) * (stiffness_ * free_v);
  rhs *= h;
  const double* k = stiffness_.valuePtr();
  double* s = system_.valuePtr();
  for (Eigen::Index n = 0; n < stiffness_.nonZeros(); ++n) s[n] = (h * b + h * h) * k[n];
  for (Eigen::Index j = 0; j < free_count(); ++j) system_.coeffRef(j, j) += (1.0 + h * a) * mass_[j];
  Eigen::ConjugateGradient<Eigen::SparseMatrix<double>, Eigen::Lower | Eigen::Upper,
                           Eigen::DiagonalPreconditioner<double>>
      cg;
  cg.setTolerance(options_.tolerance);
  cg.setMaxIterations(options_.max_iterations);
  cg.compute(system_);
  const Eigen::VectorXd change = cg.solve(rhs);
  for (Eigen::Index j = 0; j < free_count(); ++j) {
    const auto d = static_cast<Eigen::Index>(free_dofs_[static_cast<std::size_t>(j)]);
    v[d] += change[j];
    q[d] += h * v[d];
  }
  return static_cast<int>(cg.iterations());
}

}  // namespace organsim::bench

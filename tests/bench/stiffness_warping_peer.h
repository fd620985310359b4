// The peer the FEM-at-60-Hz figures are set beside: the published
// interactive step of Vega FEM's simulator (Barbič and Sin), written out here
// because Vega is not a Debian package. Co-rotational linear FEM by stiffness
// warping (Müller and Gross 2004: per tetrahedron the rotation R of the polar
// decomposition of its deformation gradient, internal force R K_e (Rᵀ x − X),
// stiffness R K_e Rᵀ), implicit backward Euler with one Newton iteration per
// step (Baraff and Witkin 1998), the linear system solved by conjugate
// gradients with a Jacobi preconditioner to a relative residual of 1e-6, from
// zero, as Vega's ImplicitBackwardEulerSparse does. Lumped masses, Rayleigh
// damping C = a M + b K. For benchmarks only: it allocates, and it keeps no
// contact.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "organsim/fem/tet_mesh.h"

namespace organsim::bench {

struct PeerOptions {
  double young_modulus = 5000.0;  ///< Pa
  double poisson_ratio = 0.45;
  double density = 1000.0;          ///< kg/m³
  double mass_damping = 0.0;        ///< a, 1/s
  double stiffness_damping = 0.01;  ///< b, s (Vega's interactive default)
  double time_step = 1.0 / 60.0;    ///< s: one deformation frame
  double tolerance = 1e-6;          ///< CG's relative residual
  int max_iterations = 10000;
};

class StiffnessWarpingPeer {
 public:
  /// `clamped`: per dof, true when it is held at zero.
  StiffnessWarpingPeer(const fem::TetMesh& mesh, const std::vector<bool>& clamped, const PeerOptions& options);

  /// One implicit Euler step from (q, v) with `external` forces (N, per dof):
  /// q and v advance. Returns the conjugate-gradient iterations it took.
  int step(Eigen::VectorXd& q, Eigen::VectorXd& v, const Eigen::VectorXd& external);

  Eigen::Index free_count() const { return static_cast<Eigen::Index>(free_dofs_.size()); }

 private:
  /// Internal forces and the warped stiffness (free rows and columns) at q.
  void assemble(const Eigen::VectorXd& q);

  fem::TetMesh mesh_;
  PeerOptions options_;
  std::vector<Eigen::Matrix<double, 12, 12>> element_stiffness_;
  std::vector<Eigen::Matrix3d> rest_inverse_;  ///< per tetrahedron: Dm⁻¹
  std::vector<std::int32_t> free_index_;       ///< per dof: its free index, or −1
  std::vector<std::int32_t> free_dofs_;
  std::vector<std::int32_t> value_of_;  ///< per element entry (144 each): its index in stiffness_'s values, or −1
  Eigen::VectorXd mass_;                ///< per free dof (lumped)
  Eigen::VectorXd internal_;            ///< per dof
  Eigen::SparseMatrix<double> stiffness_, system_;  ///< free × free
};

}  // namespace organsim::bench

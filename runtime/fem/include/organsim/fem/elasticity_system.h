// The discrete system of one material on one tetrahedral mesh: the stored
// energy Π(x) of the state x, its gradient (the internal forces) and its
// Hessian (the tangent stiffness), assembled into sparse matrices whose
// pattern is fixed at construction.
//
// The state x holds 3 displacement components per node (m, node-major), then,
// for mooney-rivlin, one pressure p per tetrahedron (Pa):
//   Π = Σ_e V_e [W(F_e) + p_e (J_e − 1) − p_e²/(2κ)] − ½ Σ_faces w_f (p_e − p_j)²,
//   w_f = β (h_e + h_j) S_f / κ   (the pressure-jump stabilization, eqs. 5–7),
// so ∂Π/∂p_e = 0 is the paper's weak incompressibility (eq. 5) and the Hessian
// is the symmetric saddle-point matrix [K_uu  G; Gᵀ  −C] (C symmetric positive
// definite: the pressure mass V/κ plus the jump penalty).
//
// The degrees of freedom are split into constrained ones (fixed nodes,
// prescribed components) and free ones; the Hessian is assembled as the
// free–free block (both triangles) and the free–constrained block, which is
// what a Newton step with prescribed displacements needs.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "organsim/fem/factorization.h"
#include "organsim/fem/material.h"
#include "organsim/fem/tet_mesh.h"

namespace organsim::fem {

/// A node held elastically by what surrounds the body (a Winkler foundation:
/// docs/supports.md). Bilateral, its energy is ½ K |u|² (the force −K u in
/// every direction); unilateral, ½ K ⟨u·n⟩₊²: it pushes back only while the
/// node moves into the support, along the body's outward normal n there.
struct FoundationSpring {
  std::int32_t node = 0;
  double stiffness = 0.0;                             ///< K = k A: the foundation modulus times the node's area, N/m
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  ///< unit, outward (unilateral springs)
  bool unilateral = false;
};

class ElasticitySystem {
 public:
  /// `constrained[d]` true for every constrained degree of freedom d
  /// (size: 3 × nodes; pressures are never constrained). Throws
  /// std::invalid_argument when a tetrahedron is degenerate or inverted.
  ElasticitySystem(const TetMesh& mesh, const Material& material, const std::vector<bool>& constrained);

  const TetMesh& mesh() const noexcept { return mesh_; }
  const Material& material() const noexcept { return material_; }
  bool has_pressure() const noexcept { return material_.model == MaterialModel::mooney_rivlin; }
  Eigen::Index dof_count() const noexcept { return static_cast<Eigen::Index>(free_of_.size()); }
  Eigen::Index free_count() const noexcept { return free_count_; }
  Eigen::Index constrained_count() const noexcept { return constrained_count_; }
  /// For every dof: its index among the free dofs, or −1 − its index among the constrained ones.
  const std::vector<std::int32_t>& free_index() const noexcept { return free_of_; }

  /// Adds the foundation's springs to Π (replacing any given before).
  /// Throws std::invalid_argument for a node out of range, a stiffness that
  /// is not finite and > 0, or a unilateral spring whose normal is not a unit vector.
  void set_foundation(std::vector<FoundationSpring> springs);
  const std::vector<FoundationSpring>& foundation() const noexcept { return foundation_; }

  /// Evaluates Π's gradient at x (all dofs) into `gradient` (all dofs: N at
  /// displacement dofs, m³ at pressure dofs) and, with `tangent`, the Hessian's
  /// blocks (tangent_free(), tangent_coupling()). Returns −1, or the index of
  /// the first tetrahedron that is inverted (J ≤ 0; linear material: never),
  /// leaving the outputs undefined. Allocates nothing.
  std::int64_t assemble(const Eigen::VectorXd& x, Eigen::VectorXd& gradient, bool tangent) noexcept;
  /// The first tetrahedron inverted at x (J ≤ 0; linear material: never), or
  /// −1: what assemble() would refuse, at a fraction of its cost (the
  /// deformation gradients' determinants only).
  std::int64_t first_inverted(const Eigen::VectorXd& x) const noexcept;
  /// Π(x) (J). Returns NaN when a tetrahedron is inverted.
  double energy(const Eigen::VectorXd& x) const noexcept;

  /// With `definite`, assemble() replaces each element's material tangent
  /// ∂P/∂F by its positive semi-definite part (negative eigenvalues set to 0;
  /// Teran et al., "Robust quasistatic finite elements", 2005), so that the
  /// tangent of a displacement-only material is positive definite wherever the
  /// body is held: what an iteration that keeps a tangent for several steps
  /// needs. Off by default (the exact Hessian: Newton's quadratic convergence).
  /// For mooney-rivlin the projected part is the displacement block's (the
  /// isochoric stress and the pressure's geometric term); the pressure
  /// coupling and C stay, so the tangent stays quasi-definite.
  void set_definite_tangent(bool definite) noexcept { definite_tangent_ = definite; }

  const SparseMatrix& tangent_free() const noexcept { return free_free_; }
  const SparseMatrix& tangent_coupling() const noexcept { return free_constrained_; }

  /// The nodal forces of a body force density ρg (N; 3 per node): each
  /// tetrahedron's weight ρ g V split equally over its four nodes (exact for P1).
  Eigen::VectorXd body_force(double density, const Eigen::Vector3d& gravity) const;

  /// Per tetrahedron: reference volume (m³), deformation gradient at x, and
  /// Cauchy stress at x (Pa; linear: the small-strain stress).
  double reference_volume(std::size_t tet) const noexcept { return volume_[tet]; }
  Eigen::Matrix3d deformation_gradient(const Eigen::VectorXd& x, std::size_t tet) const noexcept;
  Eigen::Matrix3d cauchy_stress(const Eigen::VectorXd& x, std::size_t tet) const noexcept;
  /// The stabilization's faces: tetrahedra (e, j) and weight w_f (m³/Pa).
  struct JumpFace {
    std::int32_t first, second;
    double weight;
  };
  const std::vector<JumpFace>& jump_faces() const noexcept { return jump_faces_; }
  /// Mean tetrahedron diameter (m): the length scale of the convergence norm.
  double mean_diameter() const noexcept { return mean_diameter_; }

 private:
  std::int32_t local_dof(std::size_t tet, int local) const noexcept;
  /// assemble()'s gradient for the co-rotational material, its stresses in
  /// SIMD lanes (gradient zeroed by the caller).
  std::int64_t corotational_gradient(const Eigen::VectorXd& x, Eigen::VectorXd& gradient) const noexcept;
  /// The material's and the stabilization's part of assemble().
  std::int64_t assemble_body(const Eigen::VectorXd& x, Eigen::VectorXd& gradient, bool tangent) noexcept;
  /// The foundation's part: its forces into `gradient`, its stiffness into the tangent's blocks.
  void add_foundation(const Eigen::VectorXd& x, Eigen::VectorXd& gradient, bool tangent) noexcept;
  void build_pattern();

  TetMesh mesh_;
  Material material_;
  std::vector<std::int32_t> free_of_;
  Eigen::Index free_count_ = 0, constrained_count_ = 0;
  std::vector<double> volume_;                          ///< reference volumes, m³
  std::vector<Eigen::Matrix<double, 4, 3>> gradients_;  ///< ∇N_a of each tetrahedron's 4 nodes (rows), 1/m
  std::vector<JumpFace> jump_faces_;
  double mean_diameter_ = 0;
  SparseMatrix free_free_, free_constrained_;
  /// Per tetrahedron, the value offsets of its local (13 × 13 with pressure,
  /// else 12 × 12) Hessian entries: ≥ 0 into free_free_, −1 − offset into
  /// free_constrained_, kNoEntry for the constrained rows; then per jump face
  /// its 2 × 2 pressure entries.
  std::vector<std::int32_t> element_offsets_;
  std::vector<std::int32_t> face_offsets_;
  std::vector<FoundationSpring> foundation_;
  /// Per foundation spring, the offsets of its node's 3 × 3 diagonal block
  /// (column-major), as element_offsets_.
  std::vector<std::array<std::int32_t, 9>> foundation_offsets_;
  int local_size_ = 12;
  bool definite_tangent_ = false;
};

}  // namespace organsim::fem

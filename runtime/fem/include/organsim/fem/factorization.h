// Sparse symmetric factorizations for the FEM solvers (docs/fem.md#linear-solver).
//
// The tangent of a displacement-only material is positive definite near a
// stable equilibrium; PSH's is the saddle-point matrix [K G; Gᵀ −C], which is
// quasi-definite (K and C positive definite) and has an LDLᵀ factorization
// with a diagonal D for every symmetric ordering. Its inertia — as many
// negative pivots as pressures — tells a stable state's tangent from one of an
// unstable or buckled state.
//
// The runtime core ships one factorization, Eigen's simplicial LDLᵀ (AMD
// ordering); it needs nothing but Eigen and its solve allocates nothing. The
// optional `organsim::fem_direct` library (runtime/direct/) adds supernodal and
// multifrontal factorizations from SuiteSparse (CHOLMOD) and MUMPS, 5–9 times
// faster on the liver; a program opts in by passing its factory in the
// solvers' options.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

#include <Eigen/Core>
#include <Eigen/SparseCore>

#include "organsim/fem/supernodal_solve.h"

namespace organsim::fem {

using SparseMatrix = Eigen::SparseMatrix<double, Eigen::ColMajor, int>;

enum class MatrixKind : std::uint8_t {
  positive_definite,  ///< linear, co-rotational, St. VK tangents
  quasi_definite,     ///< PSH: [K G; Gᵀ −C], one negative pivot per pressure
};

/// A factorization P A Pᵀ = L D Lᵀ held in supernodes (supernodal_solve.h),
/// for solves in parts (supernodal_responses.h). Refers into the
/// factorization; valid until its next analyze() or factorize().
struct SupernodalFactor {
  const SupernodalView<double>* double_values = nullptr;  ///< L in double precision, or
  const SupernodalView<float>* single_values = nullptr;   ///< L in single precision
  const int* order = nullptr;                             ///< row i of A is row order[i] of P A Pᵀ
  const double* pivots = nullptr;                         ///< D (null: L Lᵀ, D = I)
  Eigen::Index rows = 0;
};

/// One factorization of a symmetric sparse matrix with a fixed pattern, both
/// triangles stored. Not thread-safe; one per thread.
class Factorization {
 public:
  virtual ~Factorization() = default;
  /// Orders and analyzes the pattern (once per pattern). Allocates.
  virtual void analyze(const SparseMatrix& matrix) = 0;
  /// Factorizes a matrix with the analyzed pattern. False when a pivot is
  /// zero or not finite, or the matrix is not of the kind asked for (a
  /// positive definite factorization of an indefinite matrix). Allocates.
  virtual bool factorize(const SparseMatrix& matrix) = 0;
  /// Negative pivots of the last successful factorization (Sylvester: the
  /// number of negative eigenvalues).
  virtual Eigen::Index negative_pivots() const noexcept = 0;
  /// solution = matrix⁻¹ rhs with the last factorization (the two may alias
  /// no memory). Allocates nothing after the first call when realtime_solve().
  virtual void solve(const Eigen::Ref<const Eigen::VectorXd>& rhs, Eigen::Ref<Eigen::VectorXd> solution) noexcept = 0;
  /// The same for three right-hand sides at once (a contact's three
  /// directions): one pass over the factor where the library allows it, which
  /// is what a solve costs (its memory traffic), instead of three.
  virtual void solve3(const Eigen::Ref<const Eigen::MatrixX3d>& rhs, Eigen::Ref<Eigen::MatrixX3d> solution) noexcept {
    for (Eigen::Index k = 0; k < 3; ++k) solve(rhs.col(k), solution.col(k));
  }
  /// False when solve() gives an approximation of matrix⁻¹ rhs (a factor kept
  /// in single precision, say): a preconditioner that GMRES refines
  /// (tangent_solver.h), not a solver.
  virtual bool exact() const noexcept { return true; }
  /// True when solve() and solve3() allocate nothing, takes no lock and does no I/O once
  /// it has run once after a factorize(): what a real-time loop may call.
  virtual bool realtime_solve() const noexcept = 0;
  /// The factor the real-time solves read, where it is held in supernodes
  /// (null otherwise, or before a successful factorize()).
  virtual const SupernodalFactor* supernodal_factor() const noexcept { return nullptr; }
  /// Stored entries of the factor (L, or L and U): its memory traffic per solve.
  virtual std::size_t factor_nonzeros() const noexcept = 0;
  /// What it is, for reports: "simplicial LDLT (Eigen, AMD)".
  virtual const char* name() const noexcept = 0;
};

/// What a factorization's solves are for.
enum class SolveUse : std::uint8_t {
  newton,          ///< exact solves (Newton steps), outside real-time loops
  preconditioner,  ///< approximate solves serve: GMRES refines them (tangent_solver.h)
  realtime,        ///< exact solves a real-time loop may call (realtime_solve())
  /// Real-time solves for an iteration that converges on its own residual
  /// (the FEM frames' modified Newton): a factor kept in single precision
  /// serves (solves to about 1e-7 relative on the liver), at half the memory
  /// traffic; the iteration's fixed point does not depend on it.
  realtime_iteration,
};

/// Makes a factorization for matrices of `kind` whose solves serve `use`.
/// Returns null when it has none that fits (the caller then uses the
/// simplicial one).
using FactorizationFactory = std::unique_ptr<Factorization> (*)(MatrixKind kind, SolveUse use);

/// A fill-reducing ordering of a symmetric matrix's pattern (both triangles
/// stored): the permutation P whose P A Pᵀ is factorized, as the indices of
/// Eigen's PermutationMatrix (row i of A is row permutation[i] of P A Pᵀ).
using Ordering = void (*)(const SparseMatrix& matrix, Eigen::VectorXi& permutation);

/// Eigen's simplicial LDLᵀ (no pivoting: every kind), ordered by `ordering`
/// (null: AMD, Eigen's), with real-time solves through supernodes copied from
/// its factor (supernodal_solve.h) kept in double precision, or in single
/// precision when `single_precision` (solves to about 1e-7 relative; exact()
/// still true: no refinement is needed for SolveUse::realtime_iteration).
std::unique_ptr<Factorization> make_simplicial_factorization(bool single_precision = false,
                                                             Ordering ordering = nullptr);

/// `factory`'s factorization for `kind`, or the simplicial one when the
/// factory is null or has none that fits (in single precision for
/// SolveUse::realtime_iteration).
std::unique_ptr<Factorization> make_factorization(FactorizationFactory factory, MatrixKind kind, SolveUse use);

}  // namespace organsim::fem

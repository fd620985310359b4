// Supernodal and multifrontal factorizations for the FEM solvers, from
// Debian's SuiteSparse (CHOLMOD) and MUMPS: the optional organsim::fem_direct
// library, outside the runtime core (docs/fem.md#linear-solver).
//
// - Newton solves (no real-time solves asked for): MUMPS's multifrontal LDLᵀ
//   for symmetric indefinite matrices (SYM = 2, PORD ordering), right for a
//   displacement-only tangent that is indefinite away from equilibrium; for
//   PSH's quasi-definite tangent the same in single precision, of the matrix
//   scaled by its diagonal, which GMRES refines to the Newton step's accuracy
//   (tangent_solver.h): half the factor's memory traffic per solve and 60 % of
//   the factorization's time, for a few more GMRES iterations (PSH press on
//   the liver: 104 → 64 ms per Newton iteration). Solves allocate (Fortran
//   work arrays).
// - Real-time solves of a positive definite tangent (the tangent worker's
//   definite tangents for co-rotational and St. VK): CHOLMOD's supernodal LLᵀ
//   (BLAS-3 on dense supernodes), solved by our own pass over its supernodes:
//   cholmod_solve2 calls OpenBLAS, whose triangular solve takes its buffer
//   pool's lock on every call (a 30 ms stall of the deformation loop while
//   the tangent worker factorized, now and then) and whose small-matrix GEMM
//   allocates (three columns). Ours allocates nothing and takes no lock once
//   factorized, and solves a contact's three directions in one pass.
// - Real-time solves of a quasi-definite tangent: the core's simplicial LDLᵀ
//   with its supernodal solves, ordered by CHOLMOD (METIS or AMD, whichever
//   fills less).
//
// On the shipped liver (one core): CHOLMOD factorizes the 12k-unknown
// co-rotational tangent in 31 ms (Eigen's simplicial LDLᵀ: 275 ms), MUMPS the
// 27k-unknown PSH saddle matrix in 143–161 ms (1,408 ms). Both run on the
// calling thread only (one OpenBLAS thread, OpenMP regions inactive).
//
#pragma once

#include <memory>

#include "organsim/fem/factorization.h"

namespace organsim::fem {

/// CHOLMOD's supernodal LLᵀ; with `single_precision`, the solves read a
/// single-precision copy of the factor (for SolveUse::realtime_iteration:
/// frames that iterate on their own residual).
std::unique_ptr<Factorization> make_cholmod_factorization(bool single_precision = false);
/// CHOLMOD's fill-reducing ordering (the better of AMD and METIS for the
/// pattern), as an Ordering for make_simplicial_factorization: on the shipped
/// liver's PSH tangent 5.0 M factor entries against AMD's 6.7 M.
void cholmod_ordering(const SparseMatrix& matrix, Eigen::VectorXi& permutation);
std::unique_ptr<Factorization> make_mumps_factorization();
/// Single precision, exact() false: a preconditioner for GMRES.
std::unique_ptr<Factorization> make_single_precision_mumps_factorization();

/// The FactorizationFactory of this library: MUMPS for Newton solves (single
/// precision for quasi-definite matrices where GMRES refines the solves),
/// CHOLMOD for real-time solves of positive definite matrices (solved in
/// single precision for SolveUse::realtime_iteration), and for
/// real-time solves of quasi-definite ones (no supernodal LDLᵀ without
/// pivoting here) the simplicial one ordered by cholmod_ordering.
std::unique_ptr<Factorization> direct_factorization(MatrixKind kind, SolveUse use);

}  // namespace organsim::fem

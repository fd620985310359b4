// Newton systems solved with a factorization kept across iterations
// (docs/fem.md#linear-solver).
//
// Between Newton iterations, and between load steps, a tangent changes little,
// while its factorization is the costly part of an iteration (PSH on the liver:
// 150 ms of a 180 ms iteration). So after the first factorization each system
// is solved by GMRES on the current tangent, preconditioned with the kept
// factorization: with a preconditioner that close to the inverse a few solves
// reach the tolerance, and the step is the exact Newton step to that tolerance
// (Newton keeps its quadratic convergence; this is not a modified Newton
// method). When GMRES needs more than half its iteration budget the next
// system is factorized afresh; when it misses the tolerance within the budget,
// this one is.
//
// A factorization whose solves are approximate (exact() false: MUMPS's single
// precision factor, for PSH's Newton systems) is refined the same way on its
// own tangent right after it is made, so every system is solved to the same
// tolerance whichever factorization is used.
#pragma once

#include <memory>

#include <Eigen/Core>

#include "organsim/fem/factorization.h"

namespace organsim::fem {

struct TangentSolverOptions {
  /// GMRES iterations allowed with a kept factorization before this tangent is
  /// factorized instead; 0 factorizes every tangent.
  int max_krylov_iterations = 20;
  /// A solve that needed more GMRES iterations than this makes the next
  /// tangent be factorized: the kept factorization has drifted too far.
  int refactorize_after = 8;
  /// GMRES's goal: the preconditioned residual relative to the preconditioned right-hand side.
  double krylov_tolerance = 1e-6;
};

class TangentSolver {
 public:
  TangentSolver(std::unique_ptr<Factorization> factorization, const TangentSolverOptions& options);
  TangentSolver(const TangentSolver&) = delete;
  TangentSolver& operator=(const TangentSolver&) = delete;

  /// solution = tangent⁻¹ rhs. False when a tangent that had to be factorized
  /// could not be (singular, or not of the factorization's kind). The tangent's
  /// pattern must not change between calls. Allocates.
  ///
  /// `sufficient_accuracy`: a relative residual that is enough for this system
  /// (a Newton step close to the tolerance needs fewer digits); GMRES stops at
  /// the larger of it and the options' krylov_tolerance. A fresh factorization
  /// solves to its own precision.
  bool solve(const SparseMatrix& tangent, const Eigen::VectorXd& rhs, Eigen::VectorXd& solution,
             double sufficient_accuracy = 0);

  /// Factorize at the next solve (the kept factorization belongs to a state
  /// that was abandoned, e.g. a load step being cut).
  void refactorize_next() noexcept { refactorize_next_ = true; }

  int factorizations() const noexcept { return factorizations_; }
  /// Solves done by GMRES with a kept factorization, and the GMRES iterations
  /// run (those of attempts that ended in a factorization, and those refining
  /// an approximate factorization's solve of its own tangent, included).
  int krylov_solves() const noexcept { return krylov_solves_; }
  int krylov_iterations() const noexcept { return krylov_iterations_; }
  /// Seconds spent ordering and analyzing the pattern (once; for reports).
  double analysis_seconds() const noexcept { return analysis_seconds_; }
  const char* name() const noexcept { return factorization_->name(); }

 private:
  bool krylov_solve(const SparseMatrix& tangent, const Eigen::VectorXd& rhs, Eigen::VectorXd& solution,
                    double tolerance, int max_iterations, bool with_kept_factorization);

  std::unique_ptr<Factorization> factorization_;
  TangentSolverOptions options_;
  bool analyzed_ = false, factorized_ = false, refactorize_next_ = false;
  int factorizations_ = 0, krylov_solves_ = 0, krylov_iterations_ = 0;
  double analysis_seconds_ = 0;
};

}  // namespace organsim::fem

#include "organsim/fem/tangent_solver.h"

#include <algorithm>
#include <chrono>
#include <utility>

#include <unsupported/Eigen/IterativeSolvers>

namespace organsim::fem {
namespace {

/// Eigen's preconditioner interface over a factorization of an earlier
/// tangent: computing it for the current tangent keeps the earlier factor.
class KeptFactorization {
 public:
  KeptFactorization() = default;
  template <typename Matrix>
  explicit KeptFactorization(const Matrix&) {}
  template <typename Matrix>
  KeptFactorization& analyzePattern(const Matrix&) {
    return *this;
  }
  template <typename Matrix>
  KeptFactorization& factorize(const Matrix&) {
    return *this;
  }
  template <typename Matrix>
  KeptFactorization& compute(const Matrix&) {
    return *this;
  }

  void use(Factorization* factorization) noexcept { factorization_ = factorization; }

  template <typename Rhs>
  Eigen::VectorXd solve(const Eigen::MatrixBase<Rhs>& rhs) const {
    const Eigen::VectorXd b = rhs;
    Eigen::VectorXd x(b.size());
    factorization_->solve(b, x);
    return x;
  }
  Eigen::ComputationInfo info() const noexcept { return Eigen::Success; }

 private:
  Factorization* factorization_ = nullptr;
};

/// GMRES iterations allowed to refine an approximate factorization's solve of its own tangent.
constexpr int kRefinementIterations = 20;

}  // namespace

TangentSolver::TangentSolver(std::unique_ptr<Factorization> factorization, const TangentSolverOptions& options)
    : factorization_(std::move(factorization)), options_(options) {}

bool TangentSolver::krylov_solve(const SparseMatrix& tangent, const Eigen::VectorXd& rhs, Eigen::VectorXd& solution,
                                 double tolerance, int max_iterations, bool with_kept_factorization) {
  if (!tangent.isCompressed()) {
    SparseMatrix compressed = tangent;
    compressed.makeCompressed();
    return krylov_solve(compressed, rhs, solution, tolerance, max_iterations, with_kept_factorization);
  }
  // The tangent is symmetric with both triangles stored, so its compressed
  // columns are also its compressed rows: GMRES multiplies by rows, a dot
  // product per row, instead of scattering each column into the result.
  using RowMajorMatrix = Eigen::SparseMatrix<double, Eigen::RowMajor, int>;
  const Eigen::Map<const RowMajorMatrix> by_rows(tangent.rows(), tangent.cols(), tangent.nonZeros(),
                                                 tangent.outerIndexPtr(), tangent.innerIndexPtr(), tangent.valuePtr());
  Eigen::GMRES<RowMajorMatrix, KeptFactorization> gmres;
  gmres.preconditioner().use(factorization_.get());
  gmres.setMaxIterations(max_iterations);
  gmres.set_restart(max_iterations);
  gmres.setTolerance(tolerance);
  gmres.compute(by_rows);
  solution = gmres.solve(rhs);
  krylov_iterations_ += static_cast<int>(gmres.iterations());
  if (gmres.info() != Eigen::Success || !solution.allFinite()) return false;
  // Many iterations with a kept factorization: it has drifted from the
  // tangents (refining a fresh factor's own solve says nothing of the kind).
  if (with_kept_factorization) {
    ++krylov_solves_;
    if (gmres.iterations() > options_.refactorize_after) refactorize_next_ = true;
  }
  return true;
}

bool TangentSolver::solve(const SparseMatrix& tangent, const Eigen::VectorXd& rhs, Eigen::VectorXd& solution,
                          double sufficient_accuracy) {
  const double tolerance = std::max(sufficient_accuracy, options_.krylov_tolerance);
  if (factorized_ && !refactorize_next_ && options_.max_krylov_iterations > 0 &&
      krylov_solve(tangent, rhs, solution, tolerance, options_.max_krylov_iterations, true))
    return true;
  refactorize_next_ = false;
  if (!analyzed_) {
    const auto start = std::chrono::steady_clock::now();
    factorization_->analyze(tangent);
    analysis_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    analyzed_ = true;
  }
  ++factorizations_;
  factorized_ = factorization_->factorize(tangent);
  if (!factorized_) return false;
  if (!factorization_->exact()) {
    // The tangent's own approximate factor: GMRES refines its answer in a
    // few iterations (whatever the budget for kept factorizations).
    return krylov_solve(tangent, rhs, solution, tolerance,
                        std::max(options_.max_krylov_iterations, kRefinementIterations), false);
  }
  solution.resize(rhs.size());
  factorization_->solve(rhs, solution);
  return true;
}

}  // namespace organsim::fem

#include "organsim/fem/factorization.h"

#include <cmath>

#include <Eigen/SparseCholesky>

namespace organsim::fem {
namespace {

class SimplicialFactorization final : public Factorization {
 public:
  void analyze(const SparseMatrix& matrix) override {
    ldlt_.analyzePattern(matrix);
    scratch_.resize(matrix.rows());
    scratch3_.resize(matrix.rows(), 3);
    diagonal_.resize(matrix.rows());
  }

  bool factorize(const SparseMatrix& matrix) override {
    ldlt_.factorize(matrix);
    if (ldlt_.info() != Eigen::Success) return false;
    // A pivot is zero when it is negligible next to its own row's diagonal
    // entry: rows carry different units (N/m for displacements, m³/Pa for
    // pressures, 1e-15 apart on the liver), so one threshold for all would
    // call every pressure pivot zero.
    const Eigen::VectorXd& pivots = ldlt_.vectorD();
    const auto& permutation = ldlt_.permutationP().indices();
    diagonal_ = matrix.diagonal();
    for (Eigen::Index i = 0; i < pivots.size(); ++i) {
      const double d = pivots[permutation[i]];
      if (!std::isfinite(d) || !(std::abs(d) > 1e-13 * std::abs(diagonal_[i]))) return false;
    }
    negative_ = (pivots.array() < 0).count();
    return true;
  }

  Eigen::Index negative_pivots() const noexcept override { return negative_; }

  // SimplicialLDLT::solve step by step into our own scratch (P A Pᵀ = L D Lᵀ):
  // its own solve applies the inverse permutation in place, which allocates.
  void solve(const Eigen::Ref<const Eigen::VectorXd>& rhs, Eigen::Ref<Eigen::VectorXd> solution) noexcept override {
    const auto& permutation = ldlt_.permutationP().indices();
    for (Eigen::Index i = 0; i < rhs.size(); ++i) scratch_[permutation[i]] = rhs[i];
    ldlt_.matrixL().solveInPlace(scratch_);
    scratch_.array() /= ldlt_.vectorD().array();
    ldlt_.matrixU().solveInPlace(scratch_);
    for (Eigen::Index i = 0; i < rhs.size(); ++i) solution[i] = scratch_[permutation[i]];
  }

  void solve3(const Eigen::Ref<const Eigen::MatrixX3d>& rhs, Eigen::Ref<Eigen::MatrixX3d> solution) noexcept override {
    const auto& permutation = ldlt_.permutationP().indices();
    for (Eigen::Index i = 0; i < rhs.rows(); ++i) scratch3_.row(permutation[i]) = rhs.row(i);
    ldlt_.matrixL().solveInPlace(scratch3_);
    scratch3_.array().colwise() /= ldlt_.vectorD().array();
    ldlt_.matrixU().solveInPlace(scratch3_);
    for (Eigen::Index i = 0; i < rhs.rows(); ++i) solution.row(i) = scratch3_.row(permutation[i]);
  }

  bool realtime_solve() const noexcept override { return true; }
  std::size_t factor_nonzeros() const noexcept override {
    return static_cast<std::size_t>(ldlt_.matrixL().nestedExpression().nonZeros());
  }
  const char* name() const noexcept override { return "simplicial LDLT (Eigen, AMD ordering)"; }

 private:
  Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt_;
  Eigen::VectorXd scratch_, diagonal_;
  Eigen::MatrixX3d scratch3_;
  Eigen::Index negative_ = 0;
};

}  // namespace

std::unique_ptr<Factorization> make_simplicial_factorization() { return std::make_unique<SimplicialFactorization>(); }

std::unique_ptr<Factorization> make_factorization(FactorizationFactory factory, MatrixKind kind, SolveUse use) {
  if (factory)
    if (std::unique_ptr<Factorization> made = factory(kind, use)) return made;
  return make_simplicial_factorization();
}

}  // namespace organsim::fem

#include "organsim/fem/factorization.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/SparseCholesky>

#include "organsim/fem/supernodal_solve.h"

namespace organsim::fem {
namespace {

/// Eigen's simplicial LDLᵀ for the factorization, and its factor copied into
/// supernodes (supernodal_solve.h) of `Scalar` for the solves: a
/// column-by-column solve scatters every entry of L to its own row, a
/// supernodal one streams dense blocks.
template <typename Scalar>
class SimplicialFactorization final : public Factorization {
 public:
  explicit SimplicialFactorization(Ordering ordering) : ordering_(ordering) {}

  void analyze(const SparseMatrix& matrix) override {
    // P A Pᵀ is factorized; the ordering is ours (AMD, as Eigen's own, or the
    // one given), so that it can be another library's.
    if (ordering_) {
      ordering_(matrix, order_);
      permutation_.indices() = order_;
    } else {
      Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> inverse;
      Eigen::AMDOrdering<int>()(matrix, inverse);
      permutation_ = inverse.inverse();
      order_ = permutation_.indices();
    }
    permuted_ = matrix.selfadjointView<Eigen::Lower>().twistedBy(permutation_);
    ldlt_.analyzePattern(permuted_);
    scratch_.resize(matrix.rows(), 3);
    first_.clear();  // the supernodes follow the factor's row structure, known after its first factorization
    factor_ = {};
  }

  bool factorize(const SparseMatrix& matrix) override {
    permuted_ = matrix.selfadjointView<Eigen::Lower>().twistedBy(permutation_);
    factor_ = {};
    ldlt_.factorize(permuted_);
    if (ldlt_.info() != Eigen::Success) return false;
    // A pivot is zero when it is negligible next to its own row's diagonal
    // entry: rows carry different units (N/m for displacements, m³/Pa for
    // pressures, 1e-15 apart on the liver), so one threshold for all would
    // call every pressure pivot zero.
    // Eigen returns D by value: kept here, so that a solve copies nothing.
    pivots_ = ldlt_.vectorD();
    for (Eigen::Index i = 0; i < pivots_.size(); ++i) {
      const double d = pivots_[i];
      if (!std::isfinite(d) || !(std::abs(d) > 1e-13 * std::abs(permuted_.coeff(i, i)))) return false;
    }
    negative_ = (pivots_.array() < 0).count();
    if (first_.empty()) find_supernodes();
    copy_into_supernodes();
    if constexpr (sizeof(Scalar) == sizeof(float))
      factor_.single_values = &view_;
    else
      factor_.double_values = &view_;
    factor_.order = order_.data();
    factor_.pivots = pivots_.data();
    factor_.rows = pivots_.size();
    return true;
  }

  Eigen::Index negative_pivots() const noexcept override { return negative_; }

  // P A Pᵀ = L D Lᵀ: x = Pᵀ L⁻ᵀ D⁻¹ L⁻¹ P b.
  void solve(const Eigen::Ref<const Eigen::VectorXd>& rhs, Eigen::Ref<Eigen::VectorXd> solution) noexcept override {
    for (Eigen::Index i = 0; i < rhs.size(); ++i) scratch_(order_[i], 0) = rhs[i];
    supernodal_solve(view_, pivots_.data(), scratch_, 1, below_);
    for (Eigen::Index i = 0; i < rhs.size(); ++i) solution[i] = scratch_(order_[i], 0);
  }

  void solve3(const Eigen::Ref<const Eigen::MatrixX3d>& rhs, Eigen::Ref<Eigen::MatrixX3d> solution) noexcept override {
    for (Eigen::Index i = 0; i < rhs.rows(); ++i) scratch_.row(order_[i]) = rhs.row(i);
    supernodal_solve(view_, pivots_.data(), scratch_, 3, below_);
    for (Eigen::Index i = 0; i < rhs.rows(); ++i) solution.row(i) = scratch_.row(order_[i]);
  }

  bool realtime_solve() const noexcept override { return true; }
  const SupernodalFactor* supernodal_factor() const noexcept override { return factor_.rows > 0 ? &factor_ : nullptr; }
  std::size_t factor_nonzeros() const noexcept override {
    return static_cast<std::size_t>(ldlt_.matrixL().nestedExpression().nonZeros());
  }
  const char* name() const noexcept override {
    constexpr bool single = sizeof(Scalar) == sizeof(float);
    if (ordering_)
      return single ? "simplicial LDLT (Eigen, the direct library's ordering), supernodal solves in single precision"
                    : "simplicial LDLT (Eigen, the direct library's ordering), supernodal solves";
    return single ? "simplicial LDLT (Eigen, AMD ordering), supernodal solves in single precision"
                  : "simplicial LDLT (Eigen, AMD ordering), supernodal solves";
  }

 private:
  /// Runs of columns of L (unit diagonal, strictly lower part stored) whose
  /// rows below the run are the same: column j + 1 continues column j's
  /// supernode when j's first row is j + 1 and its other rows are j + 1's.
  void find_supernodes() {
    const SparseMatrix& l = ldlt_.matrixL().nestedExpression();
    const int* start = l.outerIndexPtr();
    const int* row = l.innerIndexPtr();
    const int columns = static_cast<int>(l.cols());
    first_.assign(1, 0);
    for (int j = 0; j + 1 < columns; ++j) {
      const int count = start[j + 1] - start[j], next = start[j + 2] - start[j + 1];
      const bool continues = count == next + 1 && row[start[j]] == j + 1 &&
                             std::equal(row + start[j] + 1, row + start[j + 1], row + start[j + 1]);
      if (!continues) first_.push_back(j + 1);
    }
    first_.push_back(columns);
    const std::size_t supernodes = first_.size() - 1;
    rows_.assign(1, 0);
    value_start_.assign(1, 0);
    row_index_.clear();
    for (std::size_t s = 0; s < supernodes; ++s) {
      const int first = first_[s], n = first_[s + 1] - first;
      const int height = n + (start[first + n] - start[first + n - 1]);  // the last column's rows below the run
      for (int r = 0; r < n; ++r) row_index_.push_back(first + r);
      row_index_.insert(row_index_.end(), row + start[first + n - 1], row + start[first + n]);
      rows_.push_back(rows_.back() + height);
      value_start_.push_back(value_start_.back() + height * n);
    }
    values_.assign(static_cast<std::size_t>(value_start_.back()), Scalar(0));
    view_ = {supernodes, first_.data(), rows_.data(), value_start_.data(), row_index_.data(), values_.data()};
    below_.resize(std::max<Eigen::Index>(view_.most_rows_below(), 1), 3);
  }

  /// Column first + c of a supernode fills its block from row c (a 1 on the
  /// diagonal) down: its entries below the diagonal are the block's next rows.
  void copy_into_supernodes() noexcept {
    const SparseMatrix& l = ldlt_.matrixL().nestedExpression();
    const int* start = l.outerIndexPtr();
    const double* value = l.valuePtr();
    for (std::size_t s = 0; s < view_.supernodes; ++s) {
      const int first = first_[s], n = first_[s + 1] - first;
      const Eigen::Index height = view_.height(s);
      Scalar* block = values_.data() + value_start_[s];
      for (int c = 0; c < n; ++c) {
        Scalar* column = block + c * height;
        column[c] = Scalar(1);
        std::transform(value + start[first + c], value + start[first + c + 1], column + c + 1,
                       [](double v) { return static_cast<Scalar>(v); });
      }
    }
  }

  Ordering ordering_ = nullptr;
  Eigen::VectorXi order_;  ///< P: row i of A is row order_[i] of P A Pᵀ
  Eigen::PermutationMatrix<Eigen::Dynamic, Eigen::Dynamic, int> permutation_;
  SparseMatrix permuted_;  ///< P A Pᵀ, both triangles
  Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower, Eigen::NaturalOrdering<int>> ldlt_;
  std::vector<int> first_, rows_, value_start_, row_index_;
  std::vector<Scalar> values_;
  SupernodalView<Scalar> view_;
  SupernodalFactor factor_;
  Eigen::VectorXd pivots_;  ///< D
  Eigen::MatrixX3d scratch_, below_;
  Eigen::Index negative_ = 0;
};

}  // namespace

std::unique_ptr<Factorization> make_simplicial_factorization(bool single_precision, Ordering ordering) {
  if (single_precision) return std::make_unique<SimplicialFactorization<float>>(ordering);
  return std::make_unique<SimplicialFactorization<double>>(ordering);
}

std::unique_ptr<Factorization> make_factorization(FactorizationFactory factory, MatrixKind kind, SolveUse use) {
  if (factory)
    if (std::unique_ptr<Factorization> made = factory(kind, use)) return made;
  return make_simplicial_factorization(use == SolveUse::realtime_iteration);
}

}  // namespace organsim::fem

#include <cholmod.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "organsim/fem_direct/direct_factorizations.h"
#include "organsim/fem/supernodal_solve.h"

#include "solver_threads.h"

namespace organsim::fem {
namespace {

/// CHOLMOD's view of an Eigen matrix (compressed, both triangles stored:
/// stype −1 reads the lower one). No copy.
cholmod_sparse view(const SparseMatrix& matrix) {
  cholmod_sparse a{};
  a.nrow = a.ncol = static_cast<std::size_t>(matrix.rows());
  a.nzmax = static_cast<std::size_t>(matrix.nonZeros());
  a.p = const_cast<int*>(matrix.outerIndexPtr());
  a.i = const_cast<int*>(matrix.innerIndexPtr());
  a.x = const_cast<double*>(matrix.valuePtr());
  a.stype = -1;
  a.itype = CHOLMOD_INT;
  a.xtype = CHOLMOD_REAL;
  a.dtype = CHOLMOD_DOUBLE;
  a.sorted = 1;
  a.packed = 1;
  return a;
}

class CholmodFactorization final : public Factorization {
 public:
  explicit CholmodFactorization(bool single_precision) : single_(single_precision) {
    detail::use_one_solver_thread();
    cholmod_start(&common_);
    common_.supernodal = CHOLMOD_SUPERNODAL;
    common_.print = 0;
    common_.error_handler = nullptr;
  }
  ~CholmodFactorization() override {
    cholmod_free_factor(&factor_, &common_);
    cholmod_finish(&common_);
  }
  CholmodFactorization(const CholmodFactorization&) = delete;
  CholmodFactorization& operator=(const CholmodFactorization&) = delete;

  void analyze(const SparseMatrix& matrix) override {
    cholmod_free_factor(&factor_, &common_);
    SparseMatrix compressed = matrix;
    compressed.makeCompressed();
    cholmod_sparse a = view(compressed);
    factor_ = cholmod_analyze(&a, &common_);
    factorized_ = false;
    rows_ = matrix.rows();
  }

  bool factorize(const SparseMatrix& matrix) override {
    if (!factor_ || !matrix.isCompressed()) return false;
    cholmod_sparse a = view(matrix);
    cholmod_factorize(&a, factor_, &common_);
    // CHOLMOD_NOT_POSDEF is a warning (status > 0): the factor stops at the
    // first non-positive pivot (`minor` < n).
    factorized_ = common_.status == CHOLMOD_OK && factor_->minor == factor_->n && factor_->is_super && factor_->is_ll &&
                  factor_->Perm;
    supernodal_ = {};
    if (factorized_) size_workspace();
    return factorized_;
  }

  Eigen::Index negative_pivots() const noexcept override { return 0; }

  // Solves walk the supernodal factor with our own loops (supernodal_solve.h)
  // rather than cholmod_solve2: CHOLMOD's solves call OpenBLAS, whose
  // triangular solve takes its buffer pool's lock on every call and whose
  // small-matrix GEMM (three columns) allocates; a real-time loop may do
  // neither. P A Pᵀ = L Lᵀ, so x = Pᵀ L⁻ᵀ L⁻¹ P b.
  void solve(const Eigen::Ref<const Eigen::VectorXd>& rhs, Eigen::Ref<Eigen::VectorXd> solution) noexcept override {
    if (!factorized_) {
      solution.setConstant(std::nan(""));
      return;
    }
    const int* perm = static_cast<const int*>(factor_->Perm);
    for (Eigen::Index k = 0; k < rows_; ++k) permuted_(k, 0) = rhs[perm[k]];
    solve_permuted(1);
    for (Eigen::Index k = 0; k < rows_; ++k) solution[perm[k]] = permuted_(k, 0);
  }

  /// One pass over the factor for a contact's three directions.
  void solve3(const Eigen::Ref<const Eigen::MatrixX3d>& rhs, Eigen::Ref<Eigen::MatrixX3d> solution) noexcept override {
    if (!factorized_) {
      solution.setConstant(std::nan(""));
      return;
    }
    const int* perm = static_cast<const int*>(factor_->Perm);
    for (Eigen::Index k = 0; k < rows_; ++k) permuted_.row(k) = rhs.row(perm[k]);
    solve_permuted(3);
    for (Eigen::Index k = 0; k < rows_; ++k) solution.row(perm[k]) = permuted_.row(k);
  }

  bool realtime_solve() const noexcept override { return true; }
  const SupernodalFactor* supernodal_factor() const noexcept override { return factorized_ ? &supernodal_ : nullptr; }
  std::size_t factor_nonzeros() const noexcept override { return static_cast<std::size_t>(common_.lnz); }
  const char* name() const noexcept override {
    return single_ ? "supernodal LLT (CHOLMOD), solves in single precision" : "supernodal LLT (CHOLMOD)";
  }

 private:
  void size_workspace() {
    view_ = {factor_->nsuper,
             static_cast<const int*>(factor_->super),
             static_cast<const int*>(factor_->pi),
             static_cast<const int*>(factor_->px),
             static_cast<const int*>(factor_->s),
             static_cast<const double*>(factor_->x)};
    if (single_) {
      // Half the bytes a solve reads (it is bound by reading the factor);
      // the copy is sized once, at the first factorization.
      const auto* values = static_cast<const double*>(factor_->x);
      single_values_.resize(factor_->xsize);
      std::transform(values, values + factor_->xsize, single_values_.begin(),
                     [](double v) { return static_cast<float>(v); });
      single_view_ = {view_.supernodes,  view_.first,     view_.rows,
                      view_.value_start, view_.row_index, single_values_.data()};
    }
    permuted_.resize(rows_, 3);
    below_.resize(std::max<Eigen::Index>(view_.most_rows_below(), 1), 3);
    // CHOLMOD factors A(Perm, Perm): row Perm[k] of A is row k of P A Pᵀ.
    order_.resize(static_cast<std::size_t>(rows_));
    const int* perm = static_cast<const int*>(factor_->Perm);
    for (Eigen::Index k = 0; k < rows_; ++k) order_[static_cast<std::size_t>(perm[k])] = static_cast<int>(k);
    supernodal_.double_values = single_ ? nullptr : &view_;
    supernodal_.single_values = single_ ? &single_view_ : nullptr;
    supernodal_.order = order_.data();
    supernodal_.rows = rows_;
  }

  void solve_permuted(int columns) noexcept {
    if (single_)
      supernodal_solve(single_view_, nullptr, permuted_, columns, below_);
    else
      supernodal_solve(view_, nullptr, permuted_, columns, below_);
  }

  bool single_;
  std::vector<float> single_values_;
  SupernodalView<float> single_view_;
  cholmod_common common_{};
  cholmod_factor* factor_ = nullptr;
  Eigen::Index rows_ = 0;
  bool factorized_ = false;
  SupernodalView<double> view_;
  std::vector<int> order_;  ///< the inverse of CHOLMOD's Perm
  SupernodalFactor supernodal_;
  Eigen::MatrixX3d permuted_, below_;  // the solves' workspace, sized at factorize()
};

}  // namespace

std::unique_ptr<Factorization> make_cholmod_factorization(bool single_precision) {
  return std::make_unique<CholmodFactorization>(single_precision);
}

void cholmod_ordering(const SparseMatrix& matrix, Eigen::VectorXi& permutation) {
  detail::use_one_solver_thread();
  cholmod_common common{};
  cholmod_start(&common);
  common.print = 0;
  common.error_handler = nullptr;
  SparseMatrix compressed = matrix;
  compressed.makeCompressed();
  cholmod_sparse a = view(compressed);
  cholmod_factor* symbolic = cholmod_analyze(&a, &common);
  // CHOLMOD factors A(Perm, Perm): row Perm[k] of A is row k of P A Pᵀ.
  permutation.resize(matrix.rows());
  if (symbolic && symbolic->Perm) {
    const int* perm = static_cast<const int*>(symbolic->Perm);
    for (Eigen::Index k = 0; k < matrix.rows(); ++k) permutation[perm[k]] = static_cast<int>(k);
  } else {
    for (Eigen::Index k = 0; k < matrix.rows(); ++k) permutation[k] = static_cast<int>(k);
  }
  cholmod_free_factor(&symbolic, &common);
  cholmod_finish(&common);
}

}  // namespace organsim::fem

#include <cholmod.h>

#include <algorithm>
#include <cmath>

#include "organsim/fem/direct_factorizations.h"

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
  CholmodFactorization() {
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
    factorized_ = common_.status == CHOLMOD_OK && factor_->minor == factor_->n && factor_->is_super &&
                  factor_->is_ll && factor_->Perm;
    if (factorized_) size_workspace();
    return factorized_;
  }

  Eigen::Index negative_pivots() const noexcept override { return 0; }

  // Solves walk the supernodal factor with our own loops (supernodal_solve)
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
    supernodal_solve<1>();
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
    supernodal_solve<3>();
    for (Eigen::Index k = 0; k < rows_; ++k) solution.row(perm[k]) = permuted_.row(k);
  }

  bool realtime_solve() const noexcept override { return true; }
  std::size_t factor_nonzeros() const noexcept override { return static_cast<std::size_t>(common_.lnz); }
  const char* name() const noexcept override { return "supernodal LLT (CHOLMOD)"; }

 private:
  /// A supernode s: columns first..first + columns − 1 of L, stored as a dense
  /// column-major rows × columns block whose first `columns` rows are those
  /// columns' own (the diagonal triangle) and whose other rows are listed in
  /// row_index (the rows below).
  struct Supernode {
    Eigen::Index first, columns, rows;
    const int* row_index;
    const double* values;
  };

  Supernode supernode(std::size_t s) const noexcept {
    const int* super = static_cast<const int*>(factor_->super);
    const int* pi = static_cast<const int*>(factor_->pi);
    const int* px = static_cast<const int*>(factor_->px);
    return {super[s], super[s + 1] - super[s], pi[s + 1] - pi[s], static_cast<const int*>(factor_->s) + pi[s],
            static_cast<const double*>(factor_->x) + px[s]};
  }

  void size_workspace() {
    Eigen::Index most_below = 0;
    for (std::size_t s = 0; s < factor_->nsuper; ++s) {
      const Supernode node = supernode(s);
      most_below = std::max(most_below, node.rows - node.columns);
    }
    permuted_.resize(rows_, 3);
    below_.resize(most_below, 3);
  }

  /// Solves L Lᵀ Y = Y for the first K columns of permuted_, in place.
  template <int K>
  void supernodal_solve() noexcept {
    double* y[K];
    double* t[K];
    for (int c = 0; c < K; ++c) y[c] = permuted_.col(c).data(), t[c] = below_.col(c).data();
    const std::size_t supernodes = factor_->nsuper;

    // L Y = Y: each supernode's diagonal triangle, then its rows below as
    // L₂₁ Y₁ gathered in t and subtracted where they belong.
    for (std::size_t s = 0; s < supernodes; ++s) {
      const Supernode node = supernode(s);
      const Eigen::Index n = node.columns, below = node.rows - n;
      for (Eigen::Index j = 0; j < n; ++j) {
        const double* column = node.values + j * node.rows;
        for (int c = 0; c < K; ++c) {
          double* yc = y[c] + node.first;
          const double pivot = yc[j] /= column[j];
          for (Eigen::Index i = j + 1; i < n; ++i) yc[i] -= column[i] * pivot;
        }
      }
      if (below == 0) continue;
      for (int c = 0; c < K; ++c) std::fill(t[c], t[c] + below, 0.0);
      Eigen::Index j = 0;
      for (; j + 4 <= n; j += 4) {  // four columns per sweep: a quarter of the passes over t
        const double* l0 = node.values + j * node.rows + n;
        const double* l1 = l0 + node.rows;
        const double* l2 = l1 + node.rows;
        const double* l3 = l2 + node.rows;
        for (int c = 0; c < K; ++c) {
          const double* yj = y[c] + node.first + j;
          const double y0 = yj[0], y1 = yj[1], y2 = yj[2], y3 = yj[3];
          double* tc = t[c];
          for (Eigen::Index i = 0; i < below; ++i) tc[i] += (l0[i] * y0 + l1[i] * y1) + (l2[i] * y2 + l3[i] * y3);
        }
      }
      for (; j < n; ++j) {
        const double* l0 = node.values + j * node.rows + n;
        for (int c = 0; c < K; ++c) {
          const double y0 = y[c][node.first + j];
          double* tc = t[c];
          for (Eigen::Index i = 0; i < below; ++i) tc[i] += l0[i] * y0;
        }
      }
      const int* rows = node.row_index + n;
      for (int c = 0; c < K; ++c)
        for (Eigen::Index i = 0; i < below; ++i) y[c][rows[i]] -= t[c][i];
    }

    // Lᵀ Y = Y, supernodes in reverse: the rows below (solved already)
    // gathered in t, Y₁ −= L₂₁ᵀ t, then the diagonal triangle transposed.
    for (std::size_t s = supernodes; s-- > 0;) {
      const Supernode node = supernode(s);
      const Eigen::Index n = node.columns, below = node.rows - n;
      const int* rows = node.row_index + n;
      for (int c = 0; c < K; ++c)
        for (Eigen::Index i = 0; i < below; ++i) t[c][i] = y[c][rows[i]];
      for (Eigen::Index j = n; j-- > 0;) {
        const double* column = node.values + j * node.rows;
        const Eigen::Map<const Eigen::VectorXd> under(column + n, below), triangle(column + j + 1, n - j - 1);
        for (int c = 0; c < K; ++c) {
          double& x = y[c][node.first + j];
          x -= under.dot(Eigen::Map<const Eigen::VectorXd>(t[c], below)) +
               triangle.dot(Eigen::Map<const Eigen::VectorXd>(y[c] + node.first + j + 1, n - j - 1));
          x /= column[j];
        }
      }
    }
  }

  cholmod_common common_{};
  cholmod_factor* factor_ = nullptr;
  Eigen::Index rows_ = 0;
  bool factorized_ = false;
  Eigen::MatrixX3d permuted_, below_;  // the solves' workspace, sized at factorize()
};

}  // namespace

std::unique_ptr<Factorization> make_cholmod_factorization() { return std::make_unique<CholmodFactorization>(); }

}  // namespace organsim::fem

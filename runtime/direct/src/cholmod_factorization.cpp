#include <cholmod.h>

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
    release(one_);
    release(three_);
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
    rows_ = matrix.rows();
  }

  bool factorize(const SparseMatrix& matrix) override {
    if (!factor_ || !matrix.isCompressed()) return false;
    cholmod_sparse a = view(matrix);
    cholmod_factorize(&a, factor_, &common_);
    // CHOLMOD_NOT_POSDEF is a warning (status > 0): the factor stops at the
    // first non-positive pivot (`minor` < n).
    return common_.status == CHOLMOD_OK && factor_->minor == factor_->n;
  }

  Eigen::Index negative_pivots() const noexcept override { return 0; }

  void solve(const Eigen::Ref<const Eigen::VectorXd>& rhs, Eigen::Ref<Eigen::VectorXd> solution) noexcept override {
    const double* x = solve_columns(rhs.data(), rhs.size(), 1, one_);
    if (!x) {
      solution.setConstant(std::nan(""));
      return;
    }
    solution = Eigen::Map<const Eigen::VectorXd>(x, rows_);
  }

  void solve3(const Eigen::Ref<const Eigen::MatrixX3d>& rhs, Eigen::Ref<Eigen::MatrixX3d> solution) noexcept override {
    // Column-major with a leading dimension of rows(): what CHOLMOD reads.
    const double* x = rhs.outerStride() == rhs.rows() ? solve_columns(rhs.data(), rhs.rows(), 3, three_) : nullptr;
    if (!x) {
      Factorization::solve3(rhs, solution);
      return;
    }
    solution = Eigen::Map<const Eigen::MatrixX3d>(x, rows_, 3);
  }

  bool realtime_solve() const noexcept override { return true; }
  std::size_t factor_nonzeros() const noexcept override { return static_cast<std::size_t>(common_.lnz); }
  const char* name() const noexcept override { return "supernodal LLT (CHOLMOD)"; }

 private:
  /// cholmod_solve2's result and workspaces for one column count: it reuses
  /// them once they have the right size, so one set per count keeps solves
  /// of one and of three columns from reallocating each other's.
  struct Workspace {
    cholmod_dense *solution = nullptr, *y = nullptr, *e = nullptr;
  };

  /// The solution of A X = B (B: `rows` × `columns`, column-major) in
  /// `work.solution`, or null when CHOLMOD fails.
  const double* solve_columns(const double* rhs, Eigen::Index rows, std::size_t columns, Workspace& work) noexcept {
    cholmod_dense b{};
    b.nrow = b.d = static_cast<std::size_t>(rows);
    b.ncol = columns;
    b.nzmax = b.nrow * columns;
    b.x = const_cast<double*>(rhs);
    b.xtype = CHOLMOD_REAL;
    b.dtype = CHOLMOD_DOUBLE;
    if (!cholmod_solve2(CHOLMOD_A, factor_, &b, nullptr, &work.solution, nullptr, &work.y, &work.e, &common_))
      return nullptr;
    return static_cast<const double*>(work.solution->x);
  }

  void release(Workspace& work) {
    cholmod_free_dense(&work.solution, &common_);
    cholmod_free_dense(&work.y, &common_);
    cholmod_free_dense(&work.e, &common_);
  }

  cholmod_common common_{};
  cholmod_factor* factor_ = nullptr;
  Workspace one_, three_;
  Eigen::Index rows_ = 0;
};

}  // namespace

std::unique_ptr<Factorization> make_cholmod_factorization() { return std::make_unique<CholmodFactorization>(); }

}  // namespace organsim::fem

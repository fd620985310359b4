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
    cholmod_free_dense(&solution_, &common_);
    cholmod_free_dense(&work_y_, &common_);
    cholmod_free_dense(&work_e_, &common_);
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
    cholmod_dense b{};
    b.nrow = b.d = b.nzmax = static_cast<std::size_t>(rhs.size());
    b.ncol = 1;
    b.x = const_cast<double*>(rhs.data());
    b.xtype = CHOLMOD_REAL;
    b.dtype = CHOLMOD_DOUBLE;
    // Reuses solution_, work_y_ and work_e_ once they have the right size.
    if (!cholmod_solve2(CHOLMOD_A, factor_, &b, nullptr, &solution_, nullptr, &work_y_, &work_e_, &common_)) {
      solution.setConstant(std::nan(""));
      return;
    }
    solution = Eigen::Map<const Eigen::VectorXd>(static_cast<const double*>(solution_->x), rows_);
  }

  bool realtime_solve() const noexcept override { return true; }
  std::size_t factor_nonzeros() const noexcept override { return static_cast<std::size_t>(common_.lnz); }
  const char* name() const noexcept override { return "supernodal LLT (CHOLMOD)"; }

 private:
  cholmod_common common_{};
  cholmod_factor* factor_ = nullptr;
  cholmod_dense *solution_ = nullptr, *work_y_ = nullptr, *work_e_ = nullptr;
  Eigen::Index rows_ = 0;
};

}  // namespace

std::unique_ptr<Factorization> make_cholmod_factorization() { return std::make_unique<CholmodFactorization>(); }

}  // namespace organsim::fem

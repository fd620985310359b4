#include <dmumps_c.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <vector>

#include "organsim/fem/direct_factorizations.h"

#include "single_column_blas.h"
#include "solver_threads.h"

namespace organsim::fem {
namespace {

// MUMPS's controls are Fortran-numbered: ICNTL(i) is icntl[i - 1].
constexpr int kJobInit = -1, kJobEnd = -2, kJobAnalyze = 1, kJobFactorize = 2, kJobSolve = 3;
constexpr int kUseCommWorld = -987654;  // the sequential library's stand-in communicator

class MumpsFactorization final : public Factorization {
 public:
  MumpsFactorization() {
    detail::use_one_solver_thread();
    detail::route_single_column_blas();
    id_.job = kJobInit;
    id_.par = 1;  // this process works too
    id_.sym = 2;  // general symmetric, with pivoting: any symmetric matrix (SYM 1 would assume positive definite)
    id_.comm_fortran = kUseCommWorld;
    dmumps_c(&id_);
    if (id_.infog[0] < 0) throw std::runtime_error("MUMPS failed to start (INFOG(1) = " + std::to_string(id_.infog[0]) + ")");
    id_.icntl[0] = id_.icntl[1] = id_.icntl[2] = -1;  // no messages
    id_.icntl[3] = 0;
    // ICNTL(7) = 4: PORD, MUMPS's own nested dissection. On the liver's PSH
    // tangent its factor has 5.30 M entries (SCOTCH 5.69 M, METIS 5.84 M, AMD
    // 7.15 M), factorizes and solves the fastest, and its analysis takes 0.16 s
    // (SCOTCH 0.59 s). Named rather than left to MUMPS's automatic choice, so
    // that the same matrix is always factorized the same way.
    id_.icntl[6] = 4;
  }
  ~MumpsFactorization() override {
    id_.job = kJobEnd;
    dmumps_c(&id_);
  }
  MumpsFactorization(const MumpsFactorization&) = delete;
  MumpsFactorization& operator=(const MumpsFactorization&) = delete;

  void analyze(const SparseMatrix& matrix) override {
    // The lower triangle as 1-based triplets, and where each value sits in
    // the Eigen matrix, so that factorize() only copies values.
    rows_.clear();
    columns_.clear();
    sources_.clear();
    for (Eigen::Index column = 0; column < matrix.outerSize(); ++column)
      for (SparseMatrix::InnerIterator it(matrix, column); it; ++it)
        if (it.row() >= it.col()) {
          rows_.push_back(static_cast<int>(it.row()) + 1);
          columns_.push_back(static_cast<int>(it.col()) + 1);
          sources_.push_back(static_cast<std::size_t>(&it.value() - matrix.valuePtr()));
        }
    // For SYM = 2 the analysis reads the values too (scaling, 2 × 2 pivot
    // candidates): those of the matrix analyzed serve.
    values_.resize(rows_.size());
    for (std::size_t k = 0; k < sources_.size(); ++k) values_[k] = matrix.valuePtr()[sources_[k]];
    id_.n = static_cast<int>(matrix.rows());
    id_.nnz = static_cast<MUMPS_INT8>(rows_.size());
    id_.irn = rows_.data();
    id_.jcn = columns_.data();
    id_.a = values_.data();
    id_.job = kJobAnalyze;
    dmumps_c(&id_);
    analyzed_ = id_.infog[0] >= 0;
    workspace_.resize(static_cast<std::size_t>(matrix.rows()));
  }

  bool factorize(const SparseMatrix& matrix) override {
    if (!analyzed_ || !matrix.isCompressed()) return false;
    for (std::size_t k = 0; k < sources_.size(); ++k) values_[k] = matrix.valuePtr()[sources_[k]];
    id_.job = kJobFactorize;
    dmumps_c(&id_);
    // INFOG(1) = −8, −9: the estimated workspace was too small; more, once.
    if (id_.infog[0] == -8 || id_.infog[0] == -9) {
      id_.icntl[13] *= 2;  // ICNTL(14): percentage of extra workspace
      dmumps_c(&id_);
    }
    factorized_ = id_.infog[0] >= 0 && id_.infog[0] != 1;  // −10: singular; 1 would be a warning we do not expect
    return factorized_;
  }

  Eigen::Index negative_pivots() const noexcept override { return id_.infog[11]; }  // INFOG(12)

  void solve(const Eigen::Ref<const Eigen::VectorXd>& rhs, Eigen::Ref<Eigen::VectorXd> solution) noexcept override {
    if (!factorized_) {
      solution.setConstant(std::nan(""));
      return;
    }
    std::copy(rhs.data(), rhs.data() + rhs.size(), workspace_.begin());
    id_.rhs = workspace_.data();
    id_.nrhs = 1;
    id_.lrhs = id_.n;
    id_.job = kJobSolve;
    dmumps_c(&id_);
    if (id_.infog[0] < 0)
      solution.setConstant(std::nan(""));
    else
      solution = Eigen::Map<const Eigen::VectorXd>(workspace_.data(), rhs.size());
  }

  bool realtime_solve() const noexcept override { return false; }
  std::size_t factor_nonzeros() const noexcept override {
    // INFOG(29): entries in the factors (negative: millions).
    return id_.infog[28] >= 0 ? static_cast<std::size_t>(id_.infog[28]) : static_cast<std::size_t>(-id_.infog[28]) * 1000000;
  }
  const char* name() const noexcept override { return "multifrontal LDLT (MUMPS, symmetric indefinite)"; }

 private:
  DMUMPS_STRUC_C id_{};
  std::vector<int> rows_, columns_;
  std::vector<std::size_t> sources_;
  std::vector<double> values_, workspace_;
  bool analyzed_ = false, factorized_ = false;
};

}  // namespace

std::unique_ptr<Factorization> make_mumps_factorization() { return std::make_unique<MumpsFactorization>(); }

std::unique_ptr<Factorization> direct_factorization(MatrixKind kind, bool realtime_solve) {
  if (!realtime_solve) return make_mumps_factorization();
  return kind == MatrixKind::positive_definite ? make_cholmod_factorization() : nullptr;
}

}  // namespace organsim::fem

#include <dmumps_c.h>
#include <smumps_c.h>

#include <cmath>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "organsim/fem_direct/direct_factorizations.h"

#include "solver_threads.h"

namespace organsim::fem {
namespace {

// MUMPS's controls are Fortran-numbered: ICNTL(i) is icntl[i - 1].
constexpr int kJobInit = -1, kJobEnd = -2, kJobAnalyze = 1, kJobFactorize = 2, kJobSolve = 3;
constexpr int kUseCommWorld = -987654;  // the sequential library's stand-in communicator

/// MUMPS's double- and single-precision libraries: the same structure and
/// entry point with another element type.
template <typename Value>
struct MumpsLibrary;
template <>
struct MumpsLibrary<double> {
  using Structure = DMUMPS_STRUC_C;
  static void call(Structure* id) { dmumps_c(id); }
  static constexpr const char* name = "multifrontal LDLT (MUMPS, symmetric indefinite)";
};
template <>
struct MumpsLibrary<float> {
  using Structure = SMUMPS_STRUC_C;
  static void call(Structure* id) { smumps_c(id); }
  static constexpr const char* name =
      "multifrontal LDLT in single precision, refined by GMRES (MUMPS, symmetric indefinite)";
};

/// MUMPS's LDLᵀ of the lower triangle, in `Value` precision. The single
/// precision factor is of the matrix scaled symmetrically by its diagonal,
/// |D|^(−1/2) A |D|^(−1/2): the tangent's rows carry N/m and m³/Pa, whose
/// entries lie 1e18 apart, beyond what single precision's pivots resolve.
template <typename Value>
class MumpsFactorization final : public Factorization {
  using Library = MumpsLibrary<Value>;
  static constexpr bool kScaled = std::is_same_v<Value, float>;

 public:
  MumpsFactorization() {
    detail::use_one_solver_thread();
    id_.job = kJobInit;
    id_.par = 1;  // this process works too
    id_.sym = 2;  // general symmetric, with pivoting: any symmetric matrix (SYM 1 would assume positive definite)
    id_.comm_fortran = kUseCommWorld;
    Library::call(&id_);
    if (id_.infog[0] < 0)
      throw std::runtime_error("MUMPS failed to start (INFOG(1) = " + std::to_string(id_.infog[0]) + ")");
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
    Library::call(&id_);
  }
  MumpsFactorization(const MumpsFactorization&) = delete;
  MumpsFactorization& operator=(const MumpsFactorization&) = delete;

  void analyze(const SparseMatrix& matrix) override {
    // The lower triangle as 1-based triplets, and where each value sits in
    // the Eigen matrix, so that factorize() only copies values.
    rows_.clear();
    columns_.clear();
    sources_.clear();
    diagonal_sources_.assign(static_cast<std::size_t>(matrix.cols()), kNoDiagonal);
    for (Eigen::Index column = 0; column < matrix.outerSize(); ++column)
      for (SparseMatrix::InnerIterator it(matrix, column); it; ++it) {
        const auto source = static_cast<std::size_t>(&it.value() - matrix.valuePtr());
        if (it.row() == it.col()) diagonal_sources_[static_cast<std::size_t>(column)] = source;
        if (it.row() < it.col()) continue;
        rows_.push_back(static_cast<int>(it.row()) + 1);
        columns_.push_back(static_cast<int>(it.col()) + 1);
        sources_.push_back(source);
      }
    // For SYM = 2 the analysis reads the values too (scaling, 2 × 2 pivot
    // candidates): those of the matrix analyzed serve.
    values_.resize(rows_.size());
    copy_values(matrix);
    id_.n = static_cast<int>(matrix.rows());
    id_.nnz = static_cast<MUMPS_INT8>(rows_.size());
    id_.irn = rows_.data();
    id_.jcn = columns_.data();
    id_.a = values_.data();
    id_.job = kJobAnalyze;
    Library::call(&id_);
    analyzed_ = id_.infog[0] >= 0;
    workspace_.resize(static_cast<std::size_t>(matrix.rows()));
  }

  bool factorize(const SparseMatrix& matrix) override {
    if (!analyzed_ || !matrix.isCompressed()) return false;
    copy_values(matrix);
    id_.job = kJobFactorize;
    Library::call(&id_);
    // INFOG(1) = −8, −9: the estimated workspace was too small; more, once.
    if (id_.infog[0] == -8 || id_.infog[0] == -9) {
      id_.icntl[13] *= 2;  // ICNTL(14): percentage of extra workspace
      Library::call(&id_);
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
    for (Eigen::Index i = 0; i < rhs.size(); ++i)
      workspace_[static_cast<std::size_t>(i)] = static_cast<Value>(scaled(rhs[i], i));
    id_.rhs = workspace_.data();
    id_.nrhs = 1;
    id_.lrhs = id_.n;
    id_.job = kJobSolve;
    Library::call(&id_);
    if (id_.infog[0] < 0) {
      solution.setConstant(std::nan(""));
      return;
    }
    for (Eigen::Index i = 0; i < rhs.size(); ++i) solution[i] = scaled(workspace_[static_cast<std::size_t>(i)], i);
  }

  bool exact() const noexcept override { return !kScaled; }
  bool realtime_solve() const noexcept override { return false; }
  std::size_t factor_nonzeros() const noexcept override {
    // INFOG(29): entries in the factors (negative: millions).
    return id_.infog[28] >= 0 ? static_cast<std::size_t>(id_.infog[28])
                              : static_cast<std::size_t>(-id_.infog[28]) * 1000000;
  }
  const char* name() const noexcept override { return Library::name; }

 private:
  /// The lower triangle's values (of the scaled matrix, in single precision).
  void copy_values(const SparseMatrix& matrix) {
    const double* values = matrix.valuePtr();
    if constexpr (kScaled) {
      scale_.resize(static_cast<std::size_t>(matrix.rows()));
      for (std::size_t i = 0; i < scale_.size(); ++i) {
        const double diagonal = diagonal_sources_[i] == kNoDiagonal ? 0 : std::abs(values[diagonal_sources_[i]]);
        scale_[i] = diagonal > 0 && std::isfinite(diagonal) ? 1 / std::sqrt(diagonal) : 1;
      }
      for (std::size_t k = 0; k < sources_.size(); ++k)
        values_[k] = static_cast<Value>(values[sources_[k]] * scale_[static_cast<std::size_t>(rows_[k] - 1)] *
                                        scale_[static_cast<std::size_t>(columns_[k] - 1)]);
    } else {
      for (std::size_t k = 0; k < sources_.size(); ++k) values_[k] = values[sources_[k]];
    }
  }
  /// A right-hand side's or solution's entry times the scale of its row.
  double scaled(double value, Eigen::Index row) const noexcept {
    if constexpr (kScaled) return value * scale_[static_cast<std::size_t>(row)];
    return value;
  }

  typename Library::Structure id_{};
  std::vector<int> rows_, columns_;
  static constexpr std::size_t kNoDiagonal = ~std::size_t{0};
  std::vector<std::size_t> sources_, diagonal_sources_;  // where each value and each row's diagonal lie in the matrix
  std::vector<Value> values_, workspace_;
  std::vector<double> scale_;  // |diagonal|^(−1/2) per row (single precision)
  bool analyzed_ = false, factorized_ = false;
};

}  // namespace

std::unique_ptr<Factorization> make_mumps_factorization() { return std::make_unique<MumpsFactorization<double>>(); }

std::unique_ptr<Factorization> make_single_precision_mumps_factorization() {
  return std::make_unique<MumpsFactorization<float>>();
}

std::unique_ptr<Factorization> direct_factorization(MatrixKind kind, SolveUse use) {
  switch (use) {
    case SolveUse::newton: return make_mumps_factorization();
    case SolveUse::preconditioner:
      return kind == MatrixKind::quasi_definite ? make_single_precision_mumps_factorization()
                                                : make_mumps_factorization();
    case SolveUse::realtime:
    case SolveUse::realtime_iteration:
      if (kind == MatrixKind::positive_definite) return make_cholmod_factorization(use == SolveUse::realtime_iteration);
      return make_simplicial_factorization(use == SolveUse::realtime_iteration, cholmod_ordering);
  }
  return nullptr;
}

}  // namespace organsim::fem

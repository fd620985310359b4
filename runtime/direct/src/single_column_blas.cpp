#include "single_column_blas.h"

#include <dlfcn.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>

namespace organsim::fem::detail {
namespace {

// The BLAS's Fortran interface as C sees it: every argument by reference. The
// hidden lengths of the character arguments are left out, as CHOLMOD and
// OpenBLAS's own C definitions do (the routines read one character).
template <typename T>
using Gemm = void(const char* transa, const char* transb, const int* m, const int* n, const int* k, const T* alpha,
                  const T* a, const int* lda, const T* b, const int* ldb, const T* beta, T* c, const int* ldc);
template <typename T>
using Trsm = void(const char* side, const char* uplo, const char* transa, const char* diag, const int* m, const int* n,
                  const T* alpha, const T* a, const int* lda, T* b, const int* ldb);
template <typename T>
using Gemv = void(const char* trans, const int* m, const int* n, const T* alpha, const T* a, const int* lda, const T* x,
                  const int* incx, const T* beta, T* y, const int* incy);
template <typename T>
using Trsv = void(const char* uplo, const char* trans, const char* diag, const int* n, const T* a, const int* lda, T* x,
                  const int* incx);

/// The loaded BLAS's routines of one precision.
template <typename T>
struct LoadedBlas {
  Gemm<T>* gemm = nullptr;
  Trsm<T>* trsm = nullptr;
  Gemv<T>* gemv = nullptr;
  Trsv<T>* trsv = nullptr;

  bool complete() const noexcept { return gemm && trsm && gemv && trsv; }
};

template <typename Function>
Function* next_definition(const char* name) {
  return reinterpret_cast<Function*>(dlsym(RTLD_NEXT, name));
}

template <typename T>
const LoadedBlas<T>& loaded_blas() {
  constexpr bool single = sizeof(T) == sizeof(float);
  static const LoadedBlas<T> blas{
      next_definition<Gemm<T>>(single ? "sgemm_" : "dgemm_"), next_definition<Trsm<T>>(single ? "strsm_" : "dtrsm_"),
      next_definition<Gemv<T>>(single ? "sgemv_" : "dgemv_"), next_definition<Trsv<T>>(single ? "strsv_" : "dtrsv_")};
  return blas;
}

/// The BLAS routines, or a message and abort: a solver library called BLAS,
/// so one is loaded unless the process is broken.
template <typename T>
const LoadedBlas<T>& required_blas() {
  const LoadedBlas<T>& blas = loaded_blas<T>();
  if (!blas.complete()) {
    std::fputs("organsim: no BLAS library loaded behind the solver libraries' GEMM/TRSM\n", stderr);
    std::abort();
  }
  return blas;
}

std::atomic<std::uint64_t> routed_calls{0};

void count_routed_call() noexcept { routed_calls.fetch_add(1, std::memory_order_relaxed); }

bool transposed(const char* trans) { return *trans == 'T' || *trans == 't' || *trans == 'C' || *trans == 'c'; }

/// y ← alpha op(A) x + beta y by GEMV, op(A) rows × columns. With beta = 0, y
/// is cleared first: GEMM does not read C then (it may hold NaN), and not every
/// OpenBLAS version's GEMV skips y for beta = 0.
template <typename T>
void gemv(const LoadedBlas<T>& blas, bool transpose, int rows, int columns, const T* alpha, const T* a, const int* lda,
          const T* x, int incx, const T* beta, T* y, int incy) {
  const T one = 1;
  if (*beta == 0) {
    for (int i = 0; i < rows; ++i) y[static_cast<long>(i) * incy] = 0;
    beta = &one;
  }
  // GEMV takes A's stored shape: op(A) rows × columns is A, or Aᵀ of a columns × rows A.
  const int stored_rows = transpose ? columns : rows, stored_columns = transpose ? rows : columns;
  blas.gemv(transpose ? "T" : "N", &stored_rows, &stored_columns, alpha, a, lda, x, &incx, beta, y, &incy);
  count_routed_call();
}

// C (m × n) ← alpha op(A) op(B) + beta C, op(A) m × k, op(B) k × n.
template <typename T>
void gemm(const char* transa, const char* transb, const int* m, const int* n, const int* k, const T* alpha, const T* a,
          const int* lda, const T* b, const int* ldb, const T* beta, T* c, const int* ldc) {
  const auto& blas = required_blas<T>();
  if (*m >= 1 && *n >= 1 && *k >= 1) {
    if (*n == 1) {  // one column: c ← alpha op(A) b + beta c, b the column op(B)
      gemv(blas, transposed(transa), *m, *k, alpha, a, lda, b, transposed(transb) ? *ldb : 1, beta, c, 1);
      return;
    }
    if (*m == 1) {  // one row: cᵀ ← alpha op(B)ᵀ aᵀ + beta cᵀ, a the row op(A)
      gemv(blas, !transposed(transb), *n, *k, alpha, b, ldb, a, transposed(transa) ? 1 : *lda, beta, c, *ldc);
      return;
    }
  }
  blas.gemm(transa, transb, m, n, k, alpha, a, lda, b, ldb, beta, c, ldc);
}

// op(A) X = alpha B (side L) or X op(A) = alpha B (side R), X overwriting B (m × n).
template <typename T>
void trsm(const char* side, const char* uplo, const char* transa, const char* diag, const int* m, const int* n,
          const T* alpha, const T* a, const int* lda, T* b, const int* ldb) {
  const auto& blas = required_blas<T>();
  const bool left = *side == 'L' || *side == 'l';
  if (*alpha == 1 && *m >= 1 && *n >= 1) {
    if (left && *n == 1) {  // one column x: op(A) x = b
      const int one = 1;
      blas.trsv(uplo, transa, diag, m, a, lda, b, &one);
      count_routed_call();
      return;
    }
    if (!left && *m == 1) {  // one row x: op(A)ᵀ xᵀ = bᵀ
      blas.trsv(uplo, transposed(transa) ? "N" : "T", diag, n, a, lda, b, ldb);
      count_routed_call();
      return;
    }
  }
  blas.trsm(side, uplo, transa, diag, m, n, alpha, a, lda, b, ldb);
}

}  // namespace

std::uint64_t single_column_blas_calls() noexcept { return routed_calls.load(std::memory_order_relaxed); }

}  // namespace organsim::fem::detail

extern "C" {

void dgemm_(const char* transa, const char* transb, const int* m, const int* n, const int* k, const double* alpha,
            const double* a, const int* lda, const double* b, const int* ldb, const double* beta, double* c,
            const int* ldc) {
  organsim::fem::detail::gemm(transa, transb, m, n, k, alpha, a, lda, b, ldb, beta, c, ldc);
}

void sgemm_(const char* transa, const char* transb, const int* m, const int* n, const int* k, const float* alpha,
            const float* a, const int* lda, const float* b, const int* ldb, const float* beta, float* c,
            const int* ldc) {
  organsim::fem::detail::gemm(transa, transb, m, n, k, alpha, a, lda, b, ldb, beta, c, ldc);
}

void dtrsm_(const char* side, const char* uplo, const char* transa, const char* diag, const int* m, const int* n,
            const double* alpha, const double* a, const int* lda, double* b, const int* ldb) {
  organsim::fem::detail::trsm(side, uplo, transa, diag, m, n, alpha, a, lda, b, ldb);
}

void strsm_(const char* side, const char* uplo, const char* transa, const char* diag, const int* m, const int* n,
            const float* alpha, const float* a, const int* lda, float* b, const int* ldb) {
  organsim::fem::detail::trsm(side, uplo, transa, diag, m, n, alpha, a, lda, b, ldb);
}

}  // extern "C"

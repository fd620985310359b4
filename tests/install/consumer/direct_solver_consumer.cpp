// A program that links organsim::fem_direct and uses the BLAS itself: the
// library must leave the process's BLAS alone (no dgemm_ of its own), so this
// program's GEMM and the solver libraries' GEMM are the system BLAS library's.
// Factorizes and solves a small SPD system with CHOLMOD and MUMPS, checks the
// solutions, then prints which shared object defines dgemm_ and fails unless
// it is a BLAS library (not this executable, not an organsim library).
#include <dlfcn.h>

#include <cstdio>
#include <cstring>
#include <memory>
#include <string>

#include "organsim/fem_direct/direct_factorizations.h"

extern "C" void dgemm_(const char* transa, const char* transb, const int* m, const int* n, const int* k,
                       const double* alpha, const double* a, const int* lda, const double* b, const int* ldb,
                       const double* beta, double* c, const int* ldc);

namespace {

/// The 1-D Laplacian of n unknowns plus the identity: SPD, solved exactly.
organsim::fem::SparseMatrix laplacian(int n) {
  organsim::fem::SparseMatrix matrix(n, n);
  for (int i = 0; i < n; ++i) {
    matrix.insert(i, i) = 3.0;
    if (i > 0) matrix.insert(i, i - 1) = -1.0;
    if (i + 1 < n) matrix.insert(i, i + 1) = -1.0;
  }
  matrix.makeCompressed();
  return matrix;
}

bool solves(organsim::fem::Factorization& factorization, const char* name) {
  const organsim::fem::SparseMatrix matrix = laplacian(200);
  const Eigen::VectorXd expected = Eigen::VectorXd::LinSpaced(matrix.rows(), -1.0, 1.0);
  const Eigen::VectorXd rhs = matrix * expected;
  factorization.analyze(matrix);
  if (!factorization.factorize(matrix)) {
    std::fprintf(stderr, "direct_solver_consumer: %s did not factorize\n", name);
    return false;
  }
  Eigen::VectorXd solution(matrix.rows());
  factorization.solve(rhs, solution);
  const double error = (solution - expected).norm() / expected.norm();
  std::printf("%s: relative error %.1e\n", name, error);
  return error < 1e-10;
}

}  // namespace

int main() {
  const auto cholmod = organsim::fem::make_cholmod_factorization();
  const auto mumps = organsim::fem::make_mumps_factorization();
  if (!solves(*cholmod, "CHOLMOD") || !solves(*mumps, "MUMPS")) return 1;

  // The program's own GEMM: C = A B for 2 × 2 matrices.
  const double a[4] = {1, 2, 3, 4}, b[4] = {5, 6, 7, 8};
  double c[4] = {0, 0, 0, 0};
  const int two = 2;
  const double one = 1, zero = 0;
  dgemm_("N", "N", &two, &two, &two, &one, a, &two, b, &two, &zero, c, &two);
  if (c[0] != 23 || c[3] != 46) return 1;

  Dl_info info{};
  void* gemm = dlsym(RTLD_DEFAULT, "dgemm_");
  if (!gemm || !dladdr(gemm, &info) || !info.dli_fname) {
    std::fprintf(stderr, "direct_solver_consumer: dgemm_ not found in the process\n");
    return 1;
  }
  const std::string library = info.dli_fname;
  std::printf("dgemm_ defined by %s\n", library.c_str());
  const std::string file = library.substr(library.find_last_of('/') + 1);
  if (file.rfind("lib", 0) != 0 || file.find("blas") == std::string::npos) {
    std::fprintf(stderr, "direct_solver_consumer: dgemm_ comes from %s, not the system BLAS library\n",
                 library.c_str());
    return 1;
  }
  return 0;
}

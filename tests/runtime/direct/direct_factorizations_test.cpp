// The direct library (CHOLMOD, MUMPS) against the simplicial factorization:
// the same solutions and inertia on definite, indefinite and quasi-definite
// tangents, the same static solves, CHOLMOD's solves allocate nothing once
// warm, and the library's one-column BLAS products equal the matrix products. Its own program: it replaces malloc to
// count allocations (the libraries are C and Fortran: operator new would not see them).
#include "organsim/fem_direct/direct_factorizations.h"

#include <dlfcn.h>
#include <strings.h>

#include <cmath>
#include <cstdlib>
#include <limits>

#include <gtest/gtest.h>

#include "organsim/fem/elasticity_system.h"
#include "organsim/fem/static_solver.h"
#include "organsim/fem/tangent_solver.h"
#include "organsim/fem/tet_mesh.h"
#include "blas_kernels.h"
#include "single_column_blas.h"

extern "C" {
void dgemm_(const char*, const char*, const int*, const int*, const int*, const double*, const double*, const int*,
            const double*, const int*, const double*, double*, const int*);
void dtrsm_(const char*, const char*, const char*, const char*, const int*, const int*, const double*, const double*,
            const int*, double*, const int*);
void* __libc_malloc(std::size_t);
void* __libc_calloc(std::size_t, std::size_t);
void* __libc_realloc(void*, std::size_t);
}

namespace {
thread_local long allocations = 0;
}

extern "C" {
void* malloc(std::size_t size) {
  ++allocations;
  return __libc_malloc(size);
}
void* calloc(std::size_t count, std::size_t size) {
  ++allocations;
  return __libc_calloc(count, size);
}
void* realloc(void* p, std::size_t size) {
  ++allocations;
  return __libc_realloc(p, size);
}
}

namespace organsim::fem {
namespace {

SparseMatrix tangent_of(const Material& material, double twist, std::size_t& pressures) {
  const TetMesh mesh = curved_tube(TubeOptions{});
  std::vector<bool> constrained(3 * mesh.nodes.size(), false);
  const double top = mesh.nodes[0].z();
  for (std::size_t n = 0; n < mesh.nodes.size(); ++n)
    if (mesh.nodes[n].z() > top - 1e-9) constrained[3 * n] = constrained[3 * n + 1] = constrained[3 * n + 2] = true;
  ElasticitySystem system(mesh, material, constrained);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(system.dof_count()), gradient(system.dof_count());
  for (std::size_t n = 0; n < mesh.nodes.size(); ++n)
    if (system.free_index()[3 * n] >= 0) x[static_cast<Eigen::Index>(3 * n)] = twist * (top - mesh.nodes[n].z());
  system.assemble(x, gradient, true);
  pressures = system.has_pressure() ? mesh.tetrahedra.size() : 0;
  SparseMatrix m = system.tangent_free();
  m.makeCompressed();
  return m;
}

Eigen::VectorXd solve_with(Factorization& f, const SparseMatrix& m, const Eigen::VectorXd& rhs) {
  f.analyze(m);
  EXPECT_TRUE(f.factorize(m)) << f.name();
  Eigen::VectorXd x(m.rows());
  f.solve(rhs, x);
  // Three columns in one solve (MUMPS: the base class's three solves) agree with it.
  Eigen::MatrixX3d rhs3(m.rows(), 3), x3(m.rows(), 3);
  rhs3 << rhs, 0.5 * rhs, -rhs;
  f.solve3(rhs3, x3);
  EXPECT_LT((x3.col(0) - x).norm(), 1e-12 * x.norm()) << f.name();
  EXPECT_LT((x3.col(1) - 0.5 * x).norm(), 1e-12 * x.norm()) << f.name();
  EXPECT_LT((x3.col(2) + x).norm(), 1e-12 * x.norm()) << f.name();
  return x;
}

TEST(DirectFactorizations, AgreeWithSimplicialAndCountNegativePivots) {
  for (const Material& material : {Material::from_young(MaterialModel::corotational, 5000, 0.45),
                                   Material::mooney_rivlin_from_young(5000, 0.49, 100)}) {
    std::size_t pressures = 0;
    const SparseMatrix m = tangent_of(material, 0.005, pressures);
    const Eigen::VectorXd rhs = Eigen::VectorXd::LinSpaced(m.rows(), -1.0, 1.0);
    const auto simplicial = make_simplicial_factorization();
    const Eigen::VectorXd reference = solve_with(*simplicial, m, rhs);
    const auto mumps = make_mumps_factorization();
    EXPECT_LT((solve_with(*mumps, m, rhs) - reference).norm(), 1e-8 * reference.norm());
    EXPECT_EQ(mumps->negative_pivots(), static_cast<Eigen::Index>(pressures));
    EXPECT_EQ(simplicial->negative_pivots(), static_cast<Eigen::Index>(pressures));
    EXPECT_FALSE(mumps->realtime_solve());
    if (pressures == 0) {
      const auto cholmod = make_cholmod_factorization();
      EXPECT_LT((solve_with(*cholmod, m, rhs) - reference).norm(), 1e-8 * reference.norm());
      EXPECT_TRUE(cholmod->realtime_solve());
      // Its single-precision solves (the displacement-only materials' real-time
      // frames): the factor rounded to float, the sums kept in double.
      const auto single = make_cholmod_factorization(true);
      const double error = (solve_with(*single, m, rhs) - reference).norm() / reference.norm();
      EXPECT_LT(error, 1e-5) << material_name(material.model);
      EXPECT_GT(error, 0.0) << "the solve should read the rounded copy";
      EXPECT_TRUE(single->realtime_solve());
    }
    // The simplicial factorization in CHOLMOD's ordering (the real-time PSH
    // frames'): the same solution, inertia and no more fill than AMD's.
    const auto ordered = make_simplicial_factorization(false, cholmod_ordering);
    EXPECT_LT((solve_with(*ordered, m, rhs) - reference).norm(), 1e-8 * reference.norm());
    EXPECT_EQ(ordered->negative_pivots(), static_cast<Eigen::Index>(pressures));
    EXPECT_LE(ordered->factor_nonzeros(), simplicial->factor_nonzeros() * 11 / 10) << material_name(material.model);
  }
}

TEST(DirectFactorizations, CholmodRefusesAnIndefiniteMatrixAndMumpsCountsItsNegativePivots) {
  SparseMatrix m(3, 3);
  m.insert(0, 0) = 2.0;
  m.insert(1, 1) = -1.0;
  m.insert(2, 2) = 3.0;
  m.insert(1, 0) = m.insert(0, 1) = 0.5;
  m.makeCompressed();
  const auto cholmod = make_cholmod_factorization();
  cholmod->analyze(m);
  EXPECT_FALSE(cholmod->factorize(m));
  const auto mumps = make_mumps_factorization();
  mumps->analyze(m);
  ASSERT_TRUE(mumps->factorize(m));
  EXPECT_EQ(mumps->negative_pivots(), 1);
  Eigen::VectorXd x(3);
  mumps->solve(Eigen::Vector3d(1, 2, 3), x);
  EXPECT_LT((m * x - Eigen::Vector3d(1, 2, 3)).norm(), 1e-12);
}

TEST(DirectFactorizations, TheFactoryGivesRealTimeSolvesOnlyWhereItCanAndApproximationsOnlyToGmres) {
  for (const MatrixKind kind : {MatrixKind::positive_definite, MatrixKind::quasi_definite})
    for (const SolveUse use : {SolveUse::realtime, SolveUse::realtime_iteration}) {
      EXPECT_TRUE(direct_factorization(kind, use)->realtime_solve());
      EXPECT_TRUE(direct_factorization(kind, use)->exact());
    }
  EXPECT_STREQ(direct_factorization(MatrixKind::quasi_definite, SolveUse::realtime_iteration)->name(),
               make_simplicial_factorization(true, cholmod_ordering)->name());
  for (const MatrixKind kind : {MatrixKind::positive_definite, MatrixKind::quasi_definite}) {
    EXPECT_FALSE(direct_factorization(kind, SolveUse::newton)->realtime_solve());
    EXPECT_TRUE(direct_factorization(kind, SolveUse::newton)->exact());
  }
  EXPECT_FALSE(direct_factorization(MatrixKind::quasi_definite, SolveUse::preconditioner)->exact());
}

TEST(DirectFactorizations, StaticSolvesEqualTheSimplicialOnes) {
  for (const Material& material :
       {Material::from_young(MaterialModel::stvk, 5000, 0.45), Material::mooney_rivlin_from_young(5000, 0.49, 100)}) {
    StaticProblem problem;
    problem.mesh = curved_tube(TubeOptions{});
    problem.material = material;
    problem.density = 1000;
    problem.gravity = {0, 0, -9.81};
    const double top = problem.mesh.nodes[0].z();
    for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n)
      if (problem.mesh.nodes[n].z() > top - 1e-9) problem.fixed.push_back(static_cast<std::int32_t>(n));
    problem.load_steps = 2;
    const StaticSolution simplicial = solve_static(problem);
    SolverOptions options;
    options.factorization = &direct_factorization;
    const StaticSolution direct = solve_static(problem, options);
    ASSERT_TRUE(simplicial.converged && direct.converged) << direct.error;
    const bool saddle = material.model == MaterialModel::mooney_rivlin;
    EXPECT_EQ(direct.linear_solver,
              (saddle ? make_single_precision_mumps_factorization() : make_mumps_factorization())->name());
    EXPECT_GT(direct.displacements.cwiseAbs().maxCoeff(), 1e-4);
    EXPECT_LT((direct.displacements - simplicial.displacements).cwiseAbs().maxCoeff(),
              1e-8 * simplicial.displacements.cwiseAbs().maxCoeff());
  }
}

TEST(DirectFactorizations, SinglePrecisionMumpsIsAPreconditionerThatGmresRefines) {
  std::size_t pressures = 0;
  const SparseMatrix m = tangent_of(Material::mooney_rivlin_from_young(5000, 0.49, 100), 0.005, pressures);
  const auto single = make_single_precision_mumps_factorization();
  EXPECT_FALSE(single->exact());
  EXPECT_TRUE(make_mumps_factorization()->exact());
  single->analyze(m);
  ASSERT_TRUE(single->factorize(m));
  EXPECT_EQ(single->negative_pivots(), static_cast<Eigen::Index>(pressures));  // the same inertia
  const Eigen::VectorXd rhs = Eigen::VectorXd::LinSpaced(m.rows(), -1.0, 2.0);
  const Eigen::VectorXd exact = solve_with(*make_mumps_factorization(), m, rhs);
  Eigen::VectorXd x(m.rows());
  const std::uint64_t routed = detail::single_column_blas_calls();
  single->solve(rhs, x);
  EXPECT_GT(detail::single_column_blas_calls(), routed) << "single precision's one-column GEMMs were packed";
  const double error = (x - exact).norm() / exact.norm();
  EXPECT_LT(error, 1e-2) << "a useful preconditioner";
  EXPECT_GT(error, 1e-12) << "single precision cannot be this close";
  TangentSolver solver(make_single_precision_mumps_factorization(), TangentSolverOptions{});
  ASSERT_TRUE(solver.solve(m, rhs, x));
  EXPECT_EQ(solver.factorizations(), 1);
  EXPECT_GE(solver.krylov_iterations(), 1);  // the fresh factor's answer, refined
  EXPECT_LT((x - exact).norm(), 10 * TangentSolverOptions{}.krylov_tolerance * exact.norm());
}

TEST(DirectFactorizations, CholmodSolvesAllocateNothingOnceWarm) {
  std::size_t pressures = 0;
  const SparseMatrix m = tangent_of(Material::from_young(MaterialModel::linear, 5000, 0.45), 0.0, pressures);
  const auto cholmod = make_cholmod_factorization();
  cholmod->analyze(m);
  ASSERT_TRUE(cholmod->factorize(m));
  const Eigen::VectorXd rhs = Eigen::VectorXd::Ones(m.rows());
  Eigen::VectorXd x(m.rows());
  const Eigen::MatrixX3d rhs3 = Eigen::MatrixX3d::Random(m.rows(), 3);
  Eigen::MatrixX3d x3(m.rows(), 3);
  cholmod->solve(rhs, x);  // the first solve sizes the workspace
  cholmod->solve3(rhs3, x3);
  const long before = allocations;
  for (int i = 0; i < 20; ++i) {
    cholmod->solve(rhs, x);
    cholmod->solve3(rhs3, x3);
  }
  EXPECT_EQ(allocations, before);
  EXPECT_LT((m * x - rhs).norm(), 1e-9 * rhs.norm());
  EXPECT_LT((m * x3 - rhs3).norm(), 1e-9 * rhs3.norm());
  // The counter itself works: MUMPS's solves allocate.
  const auto mumps = make_mumps_factorization();
  mumps->analyze(m);
  ASSERT_TRUE(mumps->factorize(m));
  const long mumps_before = allocations;
  mumps->solve(rhs, x);
  EXPECT_GT(allocations, mumps_before);
}

using Matrix = Eigen::MatrixXd;

/// op(M) for a BLAS transpose character.
Matrix op(const char* trans, const Matrix& m) { return *trans == 'N' ? m : Matrix(m.transpose()); }

TEST(SingleColumnBlas, OneRowOrColumnProductsEqualTheMatrixProducts) {
  // Stored with leading dimensions larger than the rows (MUMPS's fronts are
  // blocks of larger arrays), C filled with NaN where beta = 0 (GEMM must not
  // read it then).
  const int k = 7, ld = 11;
  for (const char* transa : {"N", "T"})
    for (const char* transb : {"N", "T"})
      for (const double beta : {0.0, 0.5})
        for (const bool one_column : {true, false}) {
          const int m = one_column ? 5 : 1, n = one_column ? 1 : 6;
          const Matrix a = Matrix::Random(*transa == 'N' ? m : k, *transa == 'N' ? k : m);
          const Matrix b = Matrix::Random(*transb == 'N' ? k : n, *transb == 'N' ? n : k);
          Matrix a_stored = Matrix::Zero(ld, a.cols()), b_stored = Matrix::Zero(ld, b.cols());
          a_stored.topRows(a.rows()) = a;
          b_stored.topRows(b.rows()) = b;
          Matrix c_stored = Matrix::Constant(ld, n, 0.25);
          if (beta == 0) c_stored.topRows(m).setConstant(std::numeric_limits<double>::quiet_NaN());
          const Matrix c = c_stored.topRows(m);
          const double alpha = -1.5;
          const std::uint64_t routed = detail::single_column_blas_calls();
          dgemm_(transa, transb, &m, &n, &k, &alpha, a_stored.data(), &ld, b_stored.data(), &ld, &beta, c_stored.data(),
                 &ld);
          const Matrix expected =
              alpha * op(transa, a) * op(transb, b) + (beta == 0 ? Matrix::Zero(m, n) : Matrix(beta * c));
          EXPECT_LT((c_stored.topRows(m) - expected).cwiseAbs().maxCoeff(), 1e-14)
              << transa << transb << " beta " << beta << (one_column ? " one column" : " one row");
          EXPECT_EQ(detail::single_column_blas_calls(), routed + 1);
          EXPECT_TRUE((c_stored.bottomRows(ld - m).array() == 0.25).all()) << "wrote past the rows of C";
        }
}

TEST(SingleColumnBlas, OneRowOrColumnTriangularSolvesEqualTheMatrixSolves) {
  const int size = 6, ld = 9;
  for (const char* uplo : {"U", "L"})
    for (const char* trans : {"N", "T"})
      for (const char* diag : {"N", "U"})
        for (const bool left : {true, false}) {
          Matrix a_stored = Matrix::Random(ld, size);
          a_stored.diagonal().array() += 4;  // well conditioned
          Matrix a = a_stored.topRows(size);
          a = *uplo == 'U' ? Matrix(a.triangularView<Eigen::Upper>()) : Matrix(a.triangularView<Eigen::Lower>());
          if (*diag == 'U') a.diagonal().setOnes();  // the stored diagonal is not read
          const int m = left ? size : 1, n = left ? 1 : size;
          Matrix b_stored = Matrix::Random(left ? ld : 3, n);
          const Matrix b = b_stored.topRows(m);
          const int ldb = static_cast<int>(b_stored.rows());
          const double alpha = 1;
          const std::uint64_t routed = detail::single_column_blas_calls();
          dtrsm_(left ? "L" : "R", uplo, trans, diag, &m, &n, &alpha, a_stored.data(), &ld, b_stored.data(), &ldb);
          const Matrix x = b_stored.topRows(m);
          const Matrix residual = left ? Matrix(op(trans, a) * x - b) : Matrix(x * op(trans, a) - b);
          EXPECT_LT(residual.cwiseAbs().maxCoeff(), 1e-12) << uplo << trans << diag << (left ? " left" : " right");
          EXPECT_EQ(detail::single_column_blas_calls(), routed + 1);
        }
}

TEST(SingleColumnBlas, MumpsSolvesOneSystemWithTheMatrixVectorRoutines) {
  std::size_t pressures = 0;
  const SparseMatrix tangent = tangent_of(Material::mooney_rivlin_from_young(1e6, 0.49, 100), 0.05, pressures);
  const auto mumps = make_mumps_factorization();
  mumps->analyze(tangent);
  ASSERT_TRUE(mumps->factorize(tangent));
  const Eigen::VectorXd rhs = Eigen::VectorXd::Random(tangent.rows());
  Eigen::VectorXd x(tangent.rows());
  const std::uint64_t routed = detail::single_column_blas_calls();
  mumps->solve(rhs, x);
  EXPECT_GT(detail::single_column_blas_calls(), routed) << "the solve's GEMMs went to the packing GEMM";
  EXPECT_LT((tangent * x - rhs).norm(), 1e-9 * rhs.norm() * tangent.norm());
}

}  // namespace
}  // namespace organsim::fem

TEST(DirectFactorizations, TheSolverLibrariesRunOnTheCallingThreadOnly) {
  const auto factorization = organsim::fem::make_cholmod_factorization();
  // CHOLMOD (Debian's, built with OpenMP) loads libgomp; OpenBLAS may be the BLAS.
  using GetCount = int (*)();
  const auto max_active_levels = reinterpret_cast<GetCount>(dlsym(RTLD_DEFAULT, "omp_get_max_active_levels"));
  const auto blas_threads = reinterpret_cast<GetCount>(dlsym(RTLD_DEFAULT, "openblas_get_num_threads"));
  if (!max_active_levels && !blas_threads) GTEST_SKIP() << "neither libgomp nor OpenBLAS is loaded";
  if (max_active_levels) {
    EXPECT_EQ(max_active_levels(), 0) << "OpenMP regions would wake threads on the other CPU";
  }
  if (blas_threads) {
    EXPECT_EQ(blas_threads(), 1);
  }
}

TEST(BlasKernels, AProgramThatChoosesThemRunsTheCpusKernels) {
  using CoreName = char* (*)();
  const auto core_name = reinterpret_cast<CoreName>(dlsym(RTLD_DEFAULT, "openblas_get_corename"));
  if (!core_name || !core_name()) GTEST_SKIP() << "the BLAS loaded is not OpenBLAS";
  __builtin_cpu_init();
  if (!__builtin_cpu_supports("avx2")) GTEST_SKIP() << "a CPU without AVX2 keeps OpenBLAS's generic kernels";
  const char* asked = std::getenv("OPENBLAS_CORETYPE");
  if (asked && strcasecmp(asked, "prescott") == 0)
    GTEST_SKIP() << "OPENBLAS_CORETYPE=Prescott asks for the generic kernels";
  EXPECT_NE(strcasecmp(core_name(), "prescott"), 0) << "OpenBLAS runs its generic kernels on a CPU with AVX2";
}

// This program chooses OpenBLAS's kernels as organsim's own executables do.
int main(int argc, char** argv) {
  organsim::fem::use_the_cpus_blas_kernels(argv);
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}

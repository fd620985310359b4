// The direct library (CHOLMOD, MUMPS) against the simplicial factorization:
// the same solutions and inertia on definite, indefinite and quasi-definite
// tangents, the same static solves, and CHOLMOD's solves allocate nothing
// once warm. Its own program: it replaces malloc to count allocations (the
// libraries are C and Fortran: operator new would not see them).
#include "organsim/fem/direct_factorizations.h"

#include <dlfcn.h>

#include <gtest/gtest.h>

#include "organsim/fem/elasticity_system.h"
#include "organsim/fem/static_solver.h"
#include "organsim/fem/tet_mesh.h"

extern "C" {
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
    }
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

TEST(DirectFactorizations, TheFactoryGivesRealTimeSolvesOnlyWhereItCan) {
  EXPECT_EQ(direct_factorization(MatrixKind::quasi_definite, true), nullptr);
  EXPECT_TRUE(direct_factorization(MatrixKind::positive_definite, true)->realtime_solve());
  EXPECT_FALSE(direct_factorization(MatrixKind::quasi_definite, false)->realtime_solve());
}

TEST(DirectFactorizations, StaticSolvesEqualTheSimplicialOnes) {
  for (const Material& material : {Material::from_young(MaterialModel::stvk, 5000, 0.45),
                                   Material::mooney_rivlin_from_young(5000, 0.49, 100)}) {
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
    EXPECT_EQ(direct.linear_solver, make_mumps_factorization()->name());
    EXPECT_GT(direct.displacements.cwiseAbs().maxCoeff(), 1e-4);
    EXPECT_LT((direct.displacements - simplicial.displacements).cwiseAbs().maxCoeff(),
              1e-8 * simplicial.displacements.cwiseAbs().maxCoeff());
  }
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

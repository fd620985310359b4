// Newton systems solved with a kept factorization: GMRES preconditioned with
// the factorization of an earlier tangent reaches the current tangent's exact
// solution, falls back to a fresh factorization when it cannot, and a static
// solve gives the same answer in the same Newton iterations as factorizing
// every tangent.
#include "organsim/fem/tangent_solver.h"

#include <gtest/gtest.h>

#include "organsim/fem/elasticity_system.h"
#include "organsim/fem/static_solver.h"

namespace organsim::fem {
namespace {

using Eigen::Vector3d;

/// A nearly incompressible block (PSH, β = 100) clamped at z = 0, and its
/// tangents at rest and under a homogeneous stretch `strain` along z.
struct Block {
  TetMesh mesh = box_mesh({3, 3, 4}, {0.02, 0.02, 0.03});
  std::vector<bool> clamped;
  ElasticitySystem system;

  Block() : clamped(clamped_base(mesh)), system(mesh, Material::mooney_rivlin_from_young(1e5, 0.49, 100), clamped) {}

  static std::vector<bool> clamped_base(const TetMesh& mesh) {
    std::vector<bool> c(3 * mesh.nodes.size(), false);
    for (std::size_t n = 0; n < mesh.nodes.size(); ++n)
      if (mesh.nodes[n].z() < 1e-12) c[3 * n] = c[3 * n + 1] = c[3 * n + 2] = true;
    return c;
  }

  SparseMatrix tangent_at(double strain) {
    Eigen::VectorXd x = Eigen::VectorXd::Zero(system.dof_count()), gradient(system.dof_count());
    for (std::size_t n = 0; n < mesh.nodes.size(); ++n)
      x[3 * static_cast<Eigen::Index>(n) + 2] = strain * mesh.nodes[n].z();
    EXPECT_LT(system.assemble(x, gradient, true), 0);
    return system.tangent_free();
  }
};

/// A block's tangents at rest and stretched by `strain`, a right-hand side of ones, and room for the solution.
struct Systems {
  Block block;
  SparseMatrix rest, stretched;
  Eigen::VectorXd b, x;
  explicit Systems(double strain)
      : rest(block.tangent_at(0)), stretched(block.tangent_at(strain)), b(Eigen::VectorXd::Ones(rest.rows())) {}
};

Eigen::VectorXd direct_solution(const SparseMatrix& a, const Eigen::VectorXd& b) {
  auto factorization = make_simplicial_factorization();
  factorization->analyze(a);
  EXPECT_TRUE(factorization->factorize(a));
  Eigen::VectorXd x(b.size());
  factorization->solve(b, x);
  return x;
}

TEST(TangentSolver, GmresWithTheKeptFactorizationGivesTheCurrentTangentsSolution) {
  Block block;
  const SparseMatrix rest = block.tangent_at(0), stretched = block.tangent_at(0.03);
  const Eigen::VectorXd b = Eigen::VectorXd::LinSpaced(rest.rows(), -1.0, 2.0);
  const Eigen::VectorXd exact = direct_solution(stretched, b);
  EXPECT_GT((direct_solution(rest, b) - exact).norm(), 1e-3 * exact.norm());  // the kept factor's own answer is wrong
  for (const double tolerance : {TangentSolverOptions{}.krylov_tolerance, 1e-10}) {
    TangentSolverOptions options;
    options.krylov_tolerance = tolerance;
    TangentSolver solver(make_simplicial_factorization(), options);
    Eigen::VectorXd x;
    ASSERT_TRUE(solver.solve(rest, b, x));
    EXPECT_EQ(solver.factorizations(), 1);
    ASSERT_TRUE(solver.solve(stretched, b, x));
    EXPECT_EQ(solver.factorizations(), 1);  // the rest factorization, kept
    EXPECT_EQ(solver.krylov_solves(), 1);
    EXPECT_GE(solver.krylov_iterations(), 2);  // the stretch changed the tangent: one solve would not do
    EXPECT_LT((x - exact).norm(), 10 * tolerance * exact.norm()) << "GMRES tolerance " << tolerance;
  }
}

TEST(TangentSolver, ASystemThatNeedsFewerDigitsStopsGmresEarlier) {
  Systems sys(0.03);
  const Eigen::VectorXd exact = direct_solution(sys.stretched, sys.b);
  int iterations[2] = {0, 0};
  for (const int accurate : {0, 1}) {
    TangentSolver solver(make_simplicial_factorization(), TangentSolverOptions{});
    ASSERT_TRUE(solver.solve(sys.rest, sys.b, sys.x));
    const double sufficient = accurate ? 0.0 : 1e-3;  // 0: the options' 1e-6
    ASSERT_TRUE(solver.solve(sys.stretched, sys.b, sys.x, sufficient));
    iterations[accurate] = solver.krylov_iterations();
    EXPECT_LT((sys.x - exact).norm(),
              10 * std::max(sufficient, TangentSolverOptions{}.krylov_tolerance) * exact.norm());
  }
  EXPECT_LT(iterations[0], iterations[1]);
}

TEST(TangentSolver, FactorizesWhenGmresMissesTheToleranceWithinItsBudget) {
  Systems sys(0.15);
  TangentSolverOptions options;
  options.max_krylov_iterations = 1;
  TangentSolver solver(make_simplicial_factorization(), options);
  ASSERT_TRUE(solver.solve(sys.rest, sys.b, sys.x));
  ASSERT_TRUE(solver.solve(sys.stretched, sys.b, sys.x));
  EXPECT_EQ(solver.factorizations(), 2);
  EXPECT_EQ(solver.krylov_solves(), 0);
  const Eigen::VectorXd exact = direct_solution(sys.stretched, sys.b);
  EXPECT_LT((sys.x - exact).norm(), 1e-9 * exact.norm());
}

TEST(TangentSolver, ASlowGmresSolveMakesTheNextTangentBeFactorized) {
  Systems sys(0.03);
  TangentSolverOptions options;
  options.refactorize_after = 1;
  TangentSolver solver(make_simplicial_factorization(), options);
  ASSERT_TRUE(solver.solve(sys.rest, sys.b, sys.x));
  ASSERT_TRUE(solver.solve(sys.stretched, sys.b, sys.x));  // GMRES, more than one iteration
  EXPECT_EQ(solver.krylov_solves(), 1);
  ASSERT_TRUE(solver.solve(sys.stretched, sys.b, sys.x));
  EXPECT_EQ(solver.factorizations(), 2);
  ASSERT_TRUE(solver.solve(sys.stretched, sys.b, sys.x));  // now the factorization is this tangent's own: one iteration
  EXPECT_EQ(solver.krylov_solves(), 2);
  EXPECT_EQ(solver.factorizations(), 2);
}

TEST(TangentSolver, ZeroKrylovIterationsFactorizesEveryTangent) {
  Systems sys(0.03);
  TangentSolverOptions options;
  options.max_krylov_iterations = 0;
  TangentSolver solver(make_simplicial_factorization(), options);
  for (const SparseMatrix* a : {&sys.rest, &sys.stretched, &sys.stretched}) ASSERT_TRUE(solver.solve(*a, sys.b, sys.x));
  EXPECT_EQ(solver.factorizations(), 3);
  EXPECT_EQ(solver.krylov_solves(), 0);
}

TEST(TangentSolver, ASingularTangentIsReportedNotSolved) {
  Block block;
  const SparseMatrix rest = block.tangent_at(0);
  SparseMatrix singular = rest;
  singular.coeffs().setZero();
  TangentSolver solver(make_simplicial_factorization(), TangentSolverOptions{});
  Eigen::VectorXd x;
  const Eigen::VectorXd b = Eigen::VectorXd::Ones(rest.rows());
  ASSERT_TRUE(solver.solve(rest, b, x));
  EXPECT_FALSE(solver.solve(singular, b, x));  // GMRES cannot, and the factorization refuses it
  EXPECT_EQ(solver.factorizations(), 2);
}

TEST(TangentSolver, StaticSolvesAgreeWithFactorizingEveryTangent) {
  for (const Material& material : {Material::mooney_rivlin_from_young(1e5, 0.49, 100),
                                   Material::from_young(MaterialModel::corotational, 1e5, 0.45),
                                   Material::from_young(MaterialModel::stvk, 1e5, 0.45)}) {
    StaticProblem problem;
    problem.mesh = box_mesh({3, 3, 6}, {0.02, 0.02, 0.06});
    problem.material = material;
    problem.load_steps = 4;
    for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n) {
      const auto node = static_cast<std::int32_t>(n);
      if (problem.mesh.nodes[n].z() < 1e-12) problem.fixed.push_back(node);
      if (problem.mesh.nodes[n].z() > 0.06 - 1e-12) problem.prescribed.push_back({node, 0, 0.02});  // a 2 cm bend
    }
    SolverOptions every;
    every.tangent.max_krylov_iterations = 0;
    const StaticSolution factorized = solve_static(problem, every), kept = solve_static(problem);
    ASSERT_TRUE(factorized.converged && kept.converged) << factorized.error << kept.error;
    EXPECT_EQ(kept.newton_iterations, factorized.newton_iterations) << material_name(material.model);
    EXPECT_LT((kept.displacements - factorized.displacements).cwiseAbs().maxCoeff(),
              1e-9 * factorized.displacements.cwiseAbs().maxCoeff());
    EXPECT_LT((kept.pressures - factorized.pressures).norm(), 1e-8 * (1 + factorized.pressures.norm()));
    int iterations = 0;
    for (int i : kept.newton_iterations) iterations += i;
    EXPECT_EQ(kept.factorizations + kept.krylov_solves, iterations);
    EXPECT_LT(kept.factorizations, iterations / 2);
    EXPECT_EQ(factorized.factorizations, iterations);
  }
}

}  // namespace
}  // namespace organsim::fem

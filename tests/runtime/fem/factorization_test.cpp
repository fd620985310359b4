// The simplicial factorization: solves positive definite and quasi-definite
// (PSH) tangents with its supernodal solves, again after a refactorization,
// reports their inertia, and refuses a singular one; a pivot
// is judged against its own row (pressure rows are 1e-15 of displacement rows).
#include "organsim/fem/factorization.h"

#include <gtest/gtest.h>

#include "organsim/fem/elasticity_system.h"
#include "organsim/fem/tet_mesh.h"

namespace organsim::fem {
namespace {

/// The tangent of a box held at its x = 0 face (or not held), slightly deformed.
struct BoxTangent {
  TetMesh mesh = box_mesh({4, 3, 3}, {0.04, 0.03, 0.03});
  std::unique_ptr<ElasticitySystem> system;

  BoxTangent(const Material& material, bool held) {
    std::vector<bool> constrained(3 * mesh.nodes.size(), false);
    for (std::size_t n = 0; n < mesh.nodes.size(); ++n)
      if (held && mesh.nodes[n].x() < 1e-9) constrained[3 * n] = constrained[3 * n + 1] = constrained[3 * n + 2] = true;
    system = std::make_unique<ElasticitySystem>(mesh, material, constrained);
    Eigen::VectorXd x = Eigen::VectorXd::Zero(system->dof_count()), gradient(system->dof_count());
    for (std::size_t n = 0; n < mesh.nodes.size(); ++n)
      if (system->free_index()[3 * n] >= 0)
        x[static_cast<Eigen::Index>(3 * n + 2)] = 0.05 * mesh.nodes[n].x() * mesh.nodes[n].x();
    system->assemble(x, gradient, true);
  }
  const SparseMatrix& matrix() const { return system->tangent_free(); }
  Eigen::Index pressures() const {
    return system->has_pressure() ? static_cast<Eigen::Index>(mesh.tetrahedra.size()) : 0;
  }
};

/// Solves to `accuracy` (relative backward error; the three-column solve as
/// the one-column ones to round-off).
void expect_solves(Factorization& f, const SparseMatrix& matrix, double accuracy = 1e-12) {
  const Eigen::VectorXd rhs = Eigen::VectorXd::LinSpaced(matrix.rows(), -1.0, 2.0);
  Eigen::VectorXd solution(matrix.rows());
  f.solve(rhs, solution);
  // Backward error: the rows carry different units, so the residual is
  // judged against ‖A‖‖x‖ + ‖b‖, not against ‖b‖ alone.
  EXPECT_LT((matrix * solution - rhs).norm(), accuracy * (matrix.norm() * solution.norm() + rhs.norm()));
  // Three right-hand sides at once: each column as its own solve gives it.
  Eigen::MatrixX3d rhs3(matrix.rows(), 3), solution3(matrix.rows(), 3);
  rhs3 << rhs, -2.0 * rhs, Eigen::VectorXd::Ones(matrix.rows());
  f.solve3(rhs3, solution3);
  for (Eigen::Index k = 0; k < 3; ++k) {
    f.solve(rhs3.col(k), solution);
    EXPECT_LT((solution3.col(k) - solution).norm(), 1e-12 * solution.norm()) << "column " << k;
  }
}

TEST(Factorization, SimplicialSolvesDefiniteAndQuasiDefiniteTangentsWithTheirInertia) {
  for (const Material& material :
       {Material::from_young(MaterialModel::corotational, 5000, 0.45),
        Material::mooney_rivlin_from_young(5000, 0.49, 100), Material::mooney_rivlin_from_young(5000, 0.49, 0)}) {
    const BoxTangent box(material, true);
    const auto f = make_simplicial_factorization();
    f->analyze(box.matrix());
    ASSERT_TRUE(f->factorize(box.matrix())) << material_name(material.model) << " beta " << material.stabilization;
    EXPECT_EQ(f->negative_pivots(), box.pressures());
    EXPECT_TRUE(f->realtime_solve());
    EXPECT_GT(f->factor_nonzeros(), static_cast<std::size_t>(box.matrix().nonZeros() / 2));
    expect_solves(*f, box.matrix());
    // Refactorized with other values on the same pattern (the tangent worker's
    // refreshes): the solves follow the new factor.
    SparseMatrix stiffer = box.matrix();
    stiffer.diagonal() *= 1.5;
    ASSERT_TRUE(f->factorize(stiffer));
    expect_solves(*f, stiffer);
  }
}

TEST(Factorization, SimplicialInSinglePrecisionSolvesToSinglePrecision) {
  for (const Material& material : {Material::from_young(MaterialModel::corotational, 5000, 0.45),
                                   Material::mooney_rivlin_from_young(5000, 0.49, 100)}) {
    const BoxTangent box(material, true);
    const auto single = make_simplicial_factorization(true), full = make_simplicial_factorization();
    for (Factorization* f : {single.get(), full.get()}) {
      f->analyze(box.matrix());
      ASSERT_TRUE(f->factorize(box.matrix()));
    }
    EXPECT_EQ(single->negative_pivots(), box.pressures());
    expect_solves(*single, box.matrix(), 1e-6);
    // Within single precision's reach of the double-precision solve, and not
    // the same (the factor really is kept in single precision).
    const Eigen::VectorXd rhs = Eigen::VectorXd::LinSpaced(box.matrix().rows(), -1.0, 2.0);
    Eigen::VectorXd x_single(rhs.size()), x_full(rhs.size());
    single->solve(rhs, x_single);
    full->solve(rhs, x_full);
    EXPECT_LT((x_single - x_full).norm(), 1e-5 * x_full.norm()) << material_name(material.model);
    EXPECT_GT((x_single - x_full).norm(), 1e-12 * x_full.norm()) << material_name(material.model);
  }
  const FactorizationFactory none = [](MatrixKind, SolveUse) -> std::unique_ptr<Factorization> { return nullptr; };
  EXPECT_STREQ(make_factorization(none, MatrixKind::quasi_definite, SolveUse::realtime_iteration)->name(),
               make_simplicial_factorization(true)->name());
}

TEST(Factorization, SimplicialRefusesTheTangentOfABodyNotHeld) {
  const BoxTangent box(Material::from_young(MaterialModel::linear, 5000, 0.3), false);
  const auto f = make_simplicial_factorization();
  f->analyze(box.matrix());
  EXPECT_FALSE(f->factorize(box.matrix()));  // six rigid-body modes: zero pivots
}

TEST(Factorization, MakeFactorizationFallsBackToSimplicial) {
  const FactorizationFactory none = [](MatrixKind, SolveUse) -> std::unique_ptr<Factorization> { return nullptr; };
  EXPECT_STREQ(make_factorization(none, MatrixKind::quasi_definite, SolveUse::realtime)->name(),
               make_simplicial_factorization()->name());
  EXPECT_STREQ(make_factorization(nullptr, MatrixKind::positive_definite, SolveUse::newton)->name(),
               make_simplicial_factorization()->name());
}

}  // namespace
}  // namespace organsim::fem

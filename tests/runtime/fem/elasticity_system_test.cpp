// The assembled gradient is the energy's derivative and the assembled
// Hessian blocks (free–free, free–constrained) the gradient's derivative,
// stabilization included; the pressure-jump faces are the mesh's interior faces.
#include "organsim/fem/elasticity_system.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <random>

namespace organsim::fem {
namespace {

Material material_for(MaterialModel model, double stabilization = 0) {
  return model == MaterialModel::mooney_rivlin ? Material::mooney_rivlin_from_young(1e5, 0.45, stabilization)
                                               : Material::from_young(model, 1e5, 0.3);
}

std::vector<bool> some_constraints(const TetMesh& mesh) {
  std::vector<bool> constrained(3 * mesh.nodes.size(), false);
  for (std::size_t n = 0; n < mesh.nodes.size(); ++n)
    if (mesh.nodes[n].x() == 0) constrained[3 * n] = constrained[3 * n + 1] = constrained[3 * n + 2] = true;
  constrained[3 * (mesh.nodes.size() - 1) + 2] = true;  // one prescribed component
  return constrained;
}

/// A state with ~5 % random displacements of the 1 cm block and random pressures.
Eigen::VectorXd random_state(const ElasticitySystem& system, unsigned seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<double> unit(-1, 1);
  Eigen::VectorXd x(system.dof_count());
  const Eigen::Index displacement_dofs = static_cast<Eigen::Index>(3 * system.mesh().nodes.size());
  for (Eigen::Index d = 0; d < x.size(); ++d) x[d] = d < displacement_dofs ? 2e-4 * unit(random) : 5e3 * unit(random);
  return x;
}

const MaterialModel kModels[] = {MaterialModel::linear, MaterialModel::corotational, MaterialModel::stvk,
                                 MaterialModel::mooney_rivlin};

TEST(ElasticitySystem, GradientIsTheEnergysDerivative) {
  const TetMesh mesh = box_mesh({2, 2, 2}, {0.01, 0.01, 0.01});
  for (MaterialModel model : kModels) {
    ElasticitySystem system(mesh, material_for(model, 10), some_constraints(mesh));
    Eigen::VectorXd x = random_state(system, 1), gradient(system.dof_count());
    ASSERT_EQ(system.assemble(x, gradient, false), -1);
    for (Eigen::Index d = 0; d < x.size(); d += 5) {
      const double h = d < static_cast<Eigen::Index>(3 * mesh.nodes.size()) ? 1e-8 : 1e-1;
      Eigen::VectorXd plus = x, minus = x;
      plus[d] += h;
      minus[d] -= h;
      const double numeric = (system.energy(plus) - system.energy(minus)) / (2 * h);
      EXPECT_NEAR(gradient[d], numeric, 1e-6 * gradient.norm() + 1e-12) << material_name(model) << " dof " << d;
    }
  }
}

TEST(ElasticitySystem, TangentBlocksAreTheGradientsDerivative) {
  const TetMesh mesh = box_mesh({2, 2, 2}, {0.01, 0.01, 0.01});
  for (MaterialModel model : kModels) {
    ElasticitySystem system(mesh, material_for(model, 10), some_constraints(mesh));
    const Eigen::VectorXd x = random_state(system, 2);
    Eigen::VectorXd gradient(system.dof_count()), plus_gradient(system.dof_count()), minus_gradient(system.dof_count());
    ASSERT_EQ(system.assemble(x, gradient, true), -1);
    const Eigen::MatrixXd free_free = system.tangent_free(), coupling = system.tangent_coupling();
    EXPECT_NEAR((free_free - free_free.transpose()).norm(), 0, 1e-12 * free_free.norm()) << material_name(model);
    const auto& index = system.free_index();
    for (Eigen::Index d = 0; d < x.size(); ++d) {
      const double h = d < static_cast<Eigen::Index>(3 * mesh.nodes.size()) ? 1e-8 : 1e-1;
      Eigen::VectorXd plus = x, minus = x;
      plus[d] += h;
      minus[d] -= h;
      ASSERT_EQ(system.assemble(plus, plus_gradient, false), -1);
      ASSERT_EQ(system.assemble(minus, minus_gradient, false), -1);
      const Eigen::VectorXd numeric = (plus_gradient - minus_gradient) / (2 * h);
      const std::int32_t column = index[static_cast<std::size_t>(d)];
      for (Eigen::Index r = 0; r < x.size(); ++r) {
        const std::int32_t row = index[static_cast<std::size_t>(r)];
        if (row < 0) continue;
        const double analytic = column >= 0 ? free_free(row, column) : coupling(row, -1 - column);
        ASSERT_NEAR(analytic, numeric[r], 1e-5 * free_free.cwiseAbs().maxCoeff())
            << material_name(model) << " row dof " << r << " column dof " << d;
      }
    }
  }
}

// Where PSH's exact tangent is indefinite (a pressure larger than the shear
// modulus makes p ∂²J/∂F² dominate), the definite tangent the static presses
// fall back to projects the displacement block to positive semi-definite and
// keeps the pressure coupling and the pressure block: still [K G; Gᵀ −C].
TEST(ElasticitySystem, PshDefiniteTangentKeepsTheSaddleFormWithADefiniteDisplacementBlock) {
  const TetMesh mesh = box_mesh({2, 2, 2}, {0.01, 0.01, 0.01});
  ElasticitySystem system(mesh, material_for(MaterialModel::mooney_rivlin, 10), some_constraints(mesh));
  Eigen::VectorXd x = random_state(system, 3), gradient(system.dof_count());
  const Eigen::Index displacement_dofs = static_cast<Eigen::Index>(3 * mesh.nodes.size());
  x.tail(x.size() - displacement_dofs).array() *= 60.0;  // pressures of ±3e5 Pa, µ ≈ 3.4e4 Pa
  const auto& index = system.free_index();
  Eigen::Index free_displacements = 0;
  for (Eigen::Index d = 0; d < displacement_dofs; ++d) free_displacements += index[static_cast<std::size_t>(d)] >= 0;
  const auto blocks = [&](bool definite) {
    system.set_definite_tangent(definite);
    EXPECT_EQ(system.assemble(x, gradient, true), -1);
    return Eigen::MatrixXd(system.tangent_free());
  };
  const Eigen::MatrixXd exact = blocks(false), definite = blocks(true);
  // The free displacements come first in the free numbering, the pressures after them.
  const auto uu = [&](const Eigen::MatrixXd& m) { return m.topLeftCorner(free_displacements, free_displacements); };
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> exact_uu(uu(exact)), definite_uu(uu(definite));
  EXPECT_LT(exact_uu.eigenvalues().minCoeff(), 0.0) << "the state should make the exact block indefinite";
  EXPECT_GT(definite_uu.eigenvalues().minCoeff(), -1e-10 * definite_uu.eigenvalues().cwiseAbs().maxCoeff());
  const Eigen::Index rest = exact.rows() - free_displacements;
  EXPECT_EQ(exact.bottomRows(rest), definite.bottomRows(rest)) << "pressure coupling and C unchanged";
}

TEST(ElasticitySystem, StabilizationJoinsEachInteriorFaceOnce) {
  const TetMesh mesh = box_mesh({2, 1, 1}, {0.02, 0.01, 0.01});  // 12 tetrahedra
  ElasticitySystem system(mesh, material_for(MaterialModel::mooney_rivlin, 100),
                          std::vector<bool>(3 * mesh.nodes.size(), false));
  // Interior faces = (4 · tets − boundary faces) / 2; the box's boundary has 2 triangles per cell face.
  const std::size_t boundary = 2 * (2 * 2 * 1 + 2 * 1 * 1 + 2 * 2 * 1);
  EXPECT_EQ(system.jump_faces().size(), (4 * mesh.tetrahedra.size() - boundary) / 2);
  for (const auto& face : system.jump_faces()) EXPECT_GT(face.weight, 0);

  // Equal pressures everywhere: no jump, so the stabilization adds nothing.
  Eigen::VectorXd x = Eigen::VectorXd::Zero(system.dof_count()), gradient(system.dof_count());
  x.tail(static_cast<Eigen::Index>(mesh.tetrahedra.size())).setConstant(1e3);
  ASSERT_EQ(system.assemble(x, gradient, false), -1);
  for (std::size_t e = 0; e < mesh.tetrahedra.size(); ++e)
    EXPECT_NEAR(gradient[static_cast<Eigen::Index>(3 * mesh.nodes.size() + e)],
                -system.reference_volume(e) * 1e3 / system.material().bulk_modulus, 1e-20);
}

TEST(ElasticitySystem, RejectsInvertedAndDegenerateTetrahedra) {
  TetMesh mesh = box_mesh({1, 1, 1}, {0.01, 0.01, 0.01});
  std::swap(mesh.tetrahedra[3][0], mesh.tetrahedra[3][1]);
  const std::vector<bool> none(3 * mesh.nodes.size(), false);
  try {
    ElasticitySystem(mesh, material_for(MaterialModel::linear), none);
    FAIL() << "an inverted tetrahedron was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("tetrahedra[3]: negative volume"), std::string::npos) << e.what();
  }
  mesh.nodes.push_back(mesh.nodes[0]);
  mesh.tetrahedra[3] = {0, 1, 2, static_cast<std::int32_t>(mesh.nodes.size() - 1)};  // two coincident nodes
  EXPECT_THROW(
      ElasticitySystem(mesh, material_for(MaterialModel::linear), std::vector<bool>(3 * mesh.nodes.size(), false)),
      std::invalid_argument);
}

TEST(ElasticitySystem, ReportsTheFirstInvertedElement) {
  const TetMesh mesh = box_mesh({1, 1, 1}, {0.01, 0.01, 0.01});
  ElasticitySystem system(mesh, material_for(MaterialModel::stvk), std::vector<bool>(3 * mesh.nodes.size(), false));
  Eigen::VectorXd x = Eigen::VectorXd::Zero(system.dof_count()), gradient(system.dof_count());
  EXPECT_EQ(system.first_inverted(x), -1);
  x[3 * 7 + 0] = x[3 * 7 + 1] = x[3 * 7 + 2] = -0.02;  // the far corner pushed through the cube
  const std::int64_t inverted = system.assemble(x, gradient, true);
  EXPECT_GE(inverted, 0);
  // The determinants alone find the same element; the linear material never refuses.
  EXPECT_EQ(system.first_inverted(x), inverted);
  EXPECT_EQ(ElasticitySystem(mesh, material_for(MaterialModel::linear), std::vector<bool>(3 * mesh.nodes.size(), false))
                .first_inverted(x),
            -1);
}

}  // namespace
}  // namespace organsim::fem

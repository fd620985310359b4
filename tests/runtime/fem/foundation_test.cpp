// An elastic (Winkler) foundation under a body (FoundationSpring): a column
// resting on it under a uniform pressure against the closed form, equilibrium
// with the foundation's forces, the unilateral springs letting go when the body
// is lifted, and the gradient being the energy's.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <vector>

#include <Eigen/Geometry>

#include "organsim/fem/elasticity_system.h"
#include "organsim/fem/static_solver.h"

namespace organsim::fem {
namespace {

using Eigen::Vector3d;

/// The boundary triangles of `mesh` whose three nodes lie at height z (m).
std::vector<std::array<std::int32_t, 3>> faces_at_height(const TetMesh& mesh, double z) {
  std::map<std::array<std::int32_t, 3>, int> count;
  for (const Tetrahedron& t : mesh.tetrahedra)
    for (int skip = 0; skip < 4; ++skip) {
      std::array<std::int32_t, 3> face{};
      for (int k = 0, j = 0; k < 4; ++k)
        if (k != skip) face[static_cast<std::size_t>(j++)] = t[static_cast<std::size_t>(k)];
      std::sort(face.begin(), face.end());
      ++count[face];
    }
  std::vector<std::array<std::int32_t, 3>> faces;
  for (const auto& [face, n] : count)
    if (n == 1 && std::all_of(face.begin(), face.end(), [&](std::int32_t v) {
          return std::abs(mesh.nodes[static_cast<std::size_t>(v)].z() - z) < 1e-12;
        }))
      faces.push_back(face);
  return faces;
}

/// Per node, a third of the area of each of `faces` it belongs to (m²).
std::vector<double> tributary_areas(const TetMesh& mesh, const std::vector<std::array<std::int32_t, 3>>& faces) {
  std::vector<double> area(mesh.nodes.size(), 0.0);
  for (const auto& f : faces) {
    const Vector3d& a = mesh.nodes[static_cast<std::size_t>(f[0])];
    const Vector3d& b = mesh.nodes[static_cast<std::size_t>(f[1])];
    const Vector3d& c = mesh.nodes[static_cast<std::size_t>(f[2])];
    for (std::int32_t v : f) area[static_cast<std::size_t>(v)] += (b - a).cross(c - a).norm() / 6.0;
  }
  return area;
}

constexpr double kModulus = 2.5e5;  // Pa/m: E = 5 kPa over 20 mm
const Vector3d kSize(0.02, 0.02, 0.04);

/// A 20 × 20 × 40 mm column (E 5 kPa, ν 0.3) whose base rests on a foundation
/// of kModulus, its top under `pressure` (Pa, > 0 pushes down); the base's
/// corner at the origin held in x and y, and the corner along x in y.
/// `attached(x, y)`: base nodes whose springs hold both ways.
template <typename Attached>
StaticProblem column_on_foundation(double pressure, Attached attached) {
  StaticProblem p;
  p.mesh = box_mesh({3, 3, 6}, kSize);
  p.material = Material::from_young(MaterialModel::linear, 5000.0, 0.3);
  const std::vector<double> base = tributary_areas(p.mesh, faces_at_height(p.mesh, 0.0));
  const auto top_faces = faces_at_height(p.mesh, kSize.z());
  const std::vector<double> top = tributary_areas(p.mesh, top_faces);
  for (std::size_t n = 0; n < p.mesh.nodes.size(); ++n) {
    const Vector3d& x = p.mesh.nodes[n];
    const auto node = static_cast<std::int32_t>(n);
    if (base[n] > 0) p.foundation.push_back({node, kModulus * base[n], Vector3d(0, 0, -1), !attached(x.x(), x.y())});
    if (top[n] > 0) p.loads.push_back({node, 2, -pressure * top[n]});
    if (x.norm() < 1e-12) p.prescribed.push_back({node, 0, 0.0}), p.prescribed.push_back({node, 1, 0.0});
    if (std::abs(x.x() - kSize.x()) < 1e-12 && std::abs(x.y()) < 1e-12 && std::abs(x.z()) < 1e-12)
      p.prescribed.push_back({node, 1, 0.0});
  }
  return p;
}

// Winkler: the base sinks p/k everywhere and the column shortens by pH/E in
// uniaxial stress (ν p/E across): the exact solution, which P1 elements
// and a foundation lumped on the base's areas reproduce to solver tolerance.
TEST(Foundation, AColumnOnAWinklerFoundationSinksByPressureOverModulus) {
  const double pressure = 20.0;  // Pa: small strain (0.4 %), the linear material's domain
  const StaticProblem problem = column_on_foundation(pressure, [](double, double) { return false; });
  const StaticSolution s = solve_static(problem);
  ASSERT_TRUE(s.converged) << s.error;
  const double E = 5000.0, nu = 0.3;
  for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n) {
    const Vector3d& x = problem.mesh.nodes[n];
    const Vector3d expected(nu * pressure / E * x.x(), nu * pressure / E * x.y(),
                            -pressure / kModulus - pressure / E * x.z());
    EXPECT_NEAR((s.displacements.segment<3>(3 * static_cast<Eigen::Index>(n)) - expected).norm(), 0.0,
                1e-9 * expected.norm())
        << "node " << n;
  }
  // The column's top sinks p (1/k + H/E): 80 µm on the foundation, 160 µm in the column.
  EXPECT_NEAR(pressure / kModulus, 80e-6, 1e-12);
}

// Lifted by its top, the column lets go of its contacts (no force where the
// base moves away from the support) and hangs on its attachments, which
// carry the whole pull.
TEST(Foundation, UnilateralSpringsLetGoWhenTheBodyIsLiftedAndAttachmentsHold) {
  const double pressure = -20.0;  // a pull
  const auto attached = [](double x, double y) { return x < 0.0075 && y < 0.0075; };
  const StaticProblem problem = column_on_foundation(pressure, attached);
  const StaticSolution s = solve_static(problem);
  ASSERT_TRUE(s.converged) << s.error;
  double held = 0.0, pull = 0.0;
  for (const NodalLoad& load : problem.loads) pull += load.value;
  std::size_t let_go = 0;
  for (const FoundationSpring& spring : problem.foundation) {
    const Vector3d u = s.displacements.segment<3>(3 * spring.node);
    if (spring.unilateral) {
      EXPECT_LT(u.dot(spring.normal), 0.0) << "a contact moves away from the support";
      ++let_go;
    } else {
      held += spring.stiffness * u.z();
    }
  }
  EXPECT_GT(let_go, 0u);
  EXPECT_NEAR(held, pull, 1e-9 * std::abs(pull)) << "the attachments carry the whole pull";
  // Pressed, the same base pushes back everywhere: the contacts carry their share.
  const StaticSolution pressed = solve_static(column_on_foundation(20.0, attached));
  ASSERT_TRUE(pressed.converged) << pressed.error;
  for (const FoundationSpring& spring : problem.foundation)
    EXPECT_GT(pressed.displacements.segment<3>(3 * spring.node).dot(spring.normal), 0.0);
}

// The foundation's forces are its energy's gradient, and its tangent the
// gradient's derivative, on either side of a unilateral spring's release.
TEST(Foundation, GradientAndTangentAreTheEnergysDerivatives) {
  const TetMesh mesh = box_mesh({1, 1, 1}, Vector3d(0.01, 0.01, 0.01));
  std::vector<bool> constrained(3 * mesh.nodes.size(), false);
  ElasticitySystem system(mesh, Material::from_young(MaterialModel::linear, 5000.0, 0.3), constrained);
  system.set_foundation({{0, 3.0, Vector3d(0, 0, -1), true}, {1, 2.0, Vector3d::UnitZ(), false}});
  for (const double dz : {-1e-4, 1e-4}) {
    Eigen::VectorXd x = Eigen::VectorXd::Zero(system.dof_count());
    x[2] = dz, x[3] = 2e-5, x[5] = -3e-5;
    Eigen::VectorXd gradient(system.dof_count());
    ASSERT_EQ(system.assemble(x, gradient, true), -1);
    const Eigen::MatrixXd tangent = system.tangent_free();
    const double h = 1e-9;
    for (Eigen::Index d = 0; d < system.dof_count(); ++d) {
      Eigen::VectorXd plus = x, minus = x;
      plus[d] += h, minus[d] -= h;
      EXPECT_NEAR(gradient[d], (system.energy(plus) - system.energy(minus)) / (2 * h), 1e-6) << "dof " << d;
      Eigen::VectorXd g_plus(system.dof_count()), g_minus(system.dof_count());
      system.assemble(plus, g_plus, false);
      system.assemble(minus, g_minus, false);
      EXPECT_NEAR(((g_plus - g_minus) / (2 * h) - tangent.col(d)).norm(), 0.0, 1e-6) << "dof " << d;
    }
  }
  EXPECT_THROW(system.set_foundation({{99, 1.0, Vector3d::UnitZ(), false}}), std::invalid_argument);
  EXPECT_THROW(system.set_foundation({{0, 0.0, Vector3d::UnitZ(), false}}), std::invalid_argument);
  EXPECT_THROW(system.set_foundation({{0, 1.0, Vector3d(0, 0, 2), true}}), std::invalid_argument);
}

}  // namespace
}  // namespace organsim::fem

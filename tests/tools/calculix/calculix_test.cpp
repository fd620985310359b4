// Our FEM against CalculiX on the same C3D4 mesh (organsim/calculix/calculix.h):
// the same discretization, so the displacements must agree to the two solvers'
// tolerances (aim: 1e-4 of the largest displacement), not to a discretization error.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "organsim/calculix/calculix.h"

namespace organsim::fem {
namespace {

Eigen::VectorXd run_calculix(const StaticProblem& problem, const std::string& name) {
  try {
    return calculix::solve(problem, name);
  } catch (const std::exception& e) {
    ADD_FAILURE() << e.what();
    return Eigen::VectorXd::Constant(3 * static_cast<Eigen::Index>(problem.mesh.nodes.size()), std::nan(""));
  }
}

/// A 5 × 1 × 1 cm bar, fixed at x = 0, under self-weight, with its end either
/// loaded or moved.
StaticProblem bar_problem(const Material& material) {
  StaticProblem problem;
  problem.mesh = box_mesh({10, 2, 2}, {0.05, 0.01, 0.01});
  problem.material = material;
  problem.density = 1000;
  problem.gravity = {0, 0, -9.81};
  problem.load_steps = 4;
  for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n) {
    const auto node = static_cast<std::int32_t>(n);
    if (problem.mesh.nodes[n].x() == 0) problem.fixed.push_back(node);
    if (std::abs(problem.mesh.nodes[n].x() - 0.05) < 1e-12) {
      if (material.model == MaterialModel::linear)
        problem.loads.push_back({node, 2, -2e-3});
      else
        problem.prescribed.push_back({node, 2, -0.012});  // a large bend: 24 % of the length
    }
  }
  return problem;
}

double relative_difference(const Eigen::VectorXd& ours, const Eigen::VectorXd& reference) {
  double largest = 0, worst = 0;
  for (Eigen::Index n = 0; n < ours.size() / 3; ++n) {
    largest = std::max(largest, reference.segment<3>(3 * n).norm());
    worst = std::max(worst, (ours.segment<3>(3 * n) - reference.segment<3>(3 * n)).norm());
  }
  return worst / largest;
}

/// Solves `material`'s bar problem with both solvers; expects agreement to 1e-4.
void expect_agreement(const Material& material, const std::string& label) {
  const StaticProblem problem = bar_problem(material);
  const StaticSolution ours = solve_static(problem);
  ASSERT_TRUE(ours.converged) << label << ": " << ours.error;
  const double difference = relative_difference(ours.displacements, run_calculix(problem, "bar"));
  std::printf("%s: largest difference / largest displacement %.3g\n", label.c_str(), difference);
  EXPECT_LT(difference, 1e-4) << label;
}

TEST(CalculiX, LinearAgrees) { expect_agreement(Material::from_young(MaterialModel::linear, 1e6, 0.3), "linear"); }

TEST(CalculiX, StVenantKirchhoffAgrees) {
  expect_agreement(Material::from_young(MaterialModel::stvk, 1e5, 0.3), "St. Venant-Kirchhoff");
}

TEST(CalculiX, MooneyRivlinWithoutStabilizationAgrees) {
  // κ / μ = 9.7 and 50 (the paper's ν = 0.49).
  expect_agreement(Material::mooney_rivlin_from_young(1e5, 0.45, 0), "Mooney-Rivlin, nu 0.45");
  expect_agreement(Material::mooney_rivlin_from_young(1e5, 0.49, 0), "Mooney-Rivlin, nu 0.49");
}

}  // namespace
}  // namespace organsim::fem

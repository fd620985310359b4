// Our FEM against CalculiX on the same C3D4 mesh (organsim/calculix/calculix.h):
// the same discretization, so the displacements must agree to the two solvers'
// tolerances (aim: 1e-4 of the largest displacement), not to a discretization error.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "organsim/calculix/calculix.h"
#include "organsim/fem/organ_fem.h"
#include "test_models.h"

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

/// The real-time FEM model's grasp on the helper cylinder (150 mm long,
/// radius 30 mm, clamped over its x = 0 cap): a point tool touches the side's
/// top node at x = 80 mm, the jaws close, and the tool pulls it `pull` out.
/// Returns the engine model's nodal displacements once the frames have
/// converged, and fills `problem` with the same held node prescribed and the
/// same clamp, for CalculiX (docs/realtime.md#grasping).
Eigen::VectorXd grasp_and_pull(MaterialModel law, const Eigen::Vector3d& pull, StaticProblem& problem) {
  testing::CylinderSpec spec;
  spec.stations = 2;
  spec.section_polygon_vertices = 32;
  const model::OrganModel m = testing::make_cylinder_model(spec);
  OrganFemOptions options;
  options.fixed_radius = 0.031;
  options.refresh_frames = 2;
  std::int32_t node = -1;
  double best = 1e9;
  for (std::size_t n = 0; n < m.volume_vertices.size(); ++n) {
    const Eigen::Vector3d x(m.volume_vertices[n][0], m.volume_vertices[n][1], m.volume_vertices[n][2]);
    const double distance = (x - Eigen::Vector3d(0.08, 0.03, 0.0)).norm();
    if (distance < best) best = distance, node = static_cast<std::int32_t>(n);
  }
  const auto& held = m.volume_vertices[static_cast<std::size_t>(node)];
  OrganFem fem(m, law, options, 1);
  EXPECT_TRUE(fem.attach(0, {held[0], held[1], held[2]}));
  fem.grasp(0, true);
  for (int frame = 0; frame < 400; ++frame) {
    EXPECT_NE(fem.step(&pull), FrameStatus::not_finite);
    if (frame > 10 && fem.unbalanced_force() < 1e-12) break;
  }
  EXPECT_LT(fem.unbalanced_force(), 1e-9) << "the frames converged";
  problem = StaticProblem{};
  problem.mesh = tet_mesh_of(m);
  problem.material = Material::from_young(law, m.material.young_modulus, m.material.poisson_ratio);
  problem.load_steps = 4;
  for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n)
    if (problem.mesh.nodes[n].norm() <= options.fixed_radius) problem.fixed.push_back(static_cast<std::int32_t>(n));
  for (int k = 0; k < 3; ++k) problem.prescribed.push_back({node, k, pull[k]});
  return fem.displacements();
}

// A grasp in the real-time FEM model is a prescribed displacement of the held
// point: pulled 10 mm out of the cylinder's side (and 5 mm along it), the
// engine model's nodal displacements are CalculiX's with that node prescribed
// on the same C3D4 mesh, small strain and large.
TEST(CalculiX, AGraspedPointPulledOutIsAPrescribedDisplacement) {
  for (const MaterialModel law : {MaterialModel::linear, MaterialModel::stvk}) {
    StaticProblem problem;
    const Eigen::VectorXd ours = grasp_and_pull(law, {0.005, 0.010, 0.0}, problem);
    const double difference = relative_difference(ours, run_calculix(problem, "grasp"));
    std::printf("grasp, %s: largest difference / largest displacement %.3g\n",
                law == MaterialModel::linear ? "linear" : "stvk", difference);
    EXPECT_LT(difference, 1e-4);
  }
}

}  // namespace
}  // namespace organsim::fem

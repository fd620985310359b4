// Static solves: patch tests, equilibrium with gravity, uniaxial stress,
// quadratic Newton convergence, convergence under refinement (cantilever
// against beam theory, clamped compressed block), step cutting and errors.
#include "organsim/fem/static_solver.h"

#include <gtest/gtest.h>

#include <cmath>

#include <Eigen/LU>

namespace organsim::fem {
namespace {

using Eigen::Vector3d;

const MaterialModel kModels[] = {MaterialModel::linear, MaterialModel::corotational, MaterialModel::stvk,
                                 MaterialModel::mooney_rivlin};

Material material_for(MaterialModel model, double stabilization = 0) {
  return model == MaterialModel::mooney_rivlin ? Material::mooney_rivlin_from_young(1e5, 0.45, stabilization)
                                               : Material::from_young(model, 1e5, 0.3);
}

bool on_boundary(const Vector3d& p, const Vector3d& size) {
  for (int c = 0; c < 3; ++c)
    if (std::abs(p[c]) < 1e-12 || std::abs(p[c] - size[c]) < 1e-12) return true;
  return false;
}

/// The z reaction summed over the nodes at height z (N).
double reaction_z_at(const StaticProblem& problem, const StaticSolution& s, double z) {
  double sum = 0;
  for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n)
    if (std::abs(problem.mesh.nodes[n].z() - z) < 1e-12) sum += s.nodal_reactions[3 * static_cast<Eigen::Index>(n) + 2];
  return sum;
}

TEST(StaticSolver, PatchTestReproducesAnAffineFieldForEveryMaterial) {
  const Vector3d size(0.02, 0.015, 0.01);
  Eigen::Matrix3d H;  // a finite homogeneous deformation: 5–10 % strain with shear
  H << 0.08, 0.03, -0.02, 0.01, -0.05, 0.04, 0.02, 0.0, 0.06;
  for (MaterialModel model : kModels)
    for (double beta : {0.0, 100.0}) {
      if (beta > 0 && model != MaterialModel::mooney_rivlin) continue;
      StaticProblem problem;
      problem.mesh = box_mesh({3, 3, 2}, size);
      problem.material = material_for(model, beta);
      problem.load_steps = 2;
      for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n)
        if (on_boundary(problem.mesh.nodes[n], size)) {
          const Vector3d u = H * problem.mesh.nodes[n];
          for (int c = 0; c < 3; ++c) problem.prescribed.push_back({static_cast<std::int32_t>(n), c, u[c]});
        }
      const StaticSolution s = solve_static(problem);
      ASSERT_TRUE(s.converged) << material_name(model) << ": " << s.error;
      for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n)
        EXPECT_NEAR((s.displacements.segment<3>(3 * static_cast<Eigen::Index>(n)) - H * problem.mesh.nodes[n]).norm(),
                    0, 1e-9 * size.norm())
            << material_name(model) << " node " << n;
      if (model == MaterialModel::mooney_rivlin) {
        const double J = (Eigen::Matrix3d::Identity() + H).determinant();
        const double expected = problem.material.bulk_modulus * (J - 1);  // uniform: no jump to stabilize
        EXPECT_NEAR(s.pressures.maxCoeff(), expected, 1e-8 * std::abs(expected));
        EXPECT_NEAR(s.pressures.minCoeff(), expected, 1e-8 * std::abs(expected));
      }
    }
}

TEST(StaticSolver, SupportsCarryTheWeight) {
  for (MaterialModel model : kModels) {
    StaticProblem problem;
    problem.mesh = box_mesh({4, 2, 2}, {0.04, 0.01, 0.01});
    problem.material = material_for(model, 10);
    problem.density = 1000;
    problem.gravity = {0, 0, -9.81};
    problem.loads.push_back({static_cast<std::int32_t>(problem.mesh.nodes.size() - 1), 1, 0.002});
    for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n)
      if (problem.mesh.nodes[n].x() == 0) problem.fixed.push_back(static_cast<std::int32_t>(n));
    const StaticSolution s = solve_static(problem);
    ASSERT_TRUE(s.converged) << s.error;
    const double weight = 1000 * 0.04 * 0.01 * 0.01 * 9.81;
    EXPECT_NEAR(s.reaction_fixed.z(), weight, 1e-8 * weight) << material_name(model);
    EXPECT_NEAR(s.reaction_fixed.y(), -0.002, 1e-8 * weight) << material_name(model);
    EXPECT_NEAR(s.reaction_fixed.x(), 0, 1e-8 * weight) << material_name(model);
    EXPECT_EQ(s.reaction_prescribed, Vector3d::Zero());
    EXPECT_LT(s.displacements.minCoeff(), 0);  // it sags
  }
}

TEST(StaticSolver, UniaxialStressGivesYoungsModulusAndPoissonsContraction) {
  // Rollers on three faces, the top pressed down 1 %: homogeneous uniaxial
  // stress, so the linear solution is exact on any mesh.
  const Vector3d size(0.01, 0.01, 0.02);
  StaticProblem problem;
  problem.mesh = box_mesh({2, 2, 3}, size);
  problem.material = Material::from_young(MaterialModel::linear, 2e5, 0.3);
  for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n) {
    const Vector3d& p = problem.mesh.nodes[n];
    const auto node = static_cast<std::int32_t>(n);
    if (p.x() == 0) problem.prescribed.push_back({node, 0, 0});
    if (p.y() == 0) problem.prescribed.push_back({node, 1, 0});
    if (p.z() == 0) problem.prescribed.push_back({node, 2, 0});
    if (std::abs(p.z() - size.z()) < 1e-12) problem.prescribed.push_back({node, 2, -0.01 * size.z()});
  }
  const StaticSolution s = solve_static(problem);
  ASSERT_TRUE(s.converged) << s.error;
  EXPECT_NEAR(reaction_z_at(problem, s, size.z()), -2e5 * 0.01 * size.x() * size.y(), 1e-9);
  EXPECT_NEAR(reaction_z_at(problem, s, 0), 2e5 * 0.01 * size.x() * size.y(), 1e-9);
  const Eigen::Index corner = 3 * static_cast<Eigen::Index>(problem.mesh.nodes.size() - 1);
  EXPECT_NEAR(s.displacements[corner], 0.3 * 0.01 * size.x(), 1e-12);
}

TEST(StaticSolver, NewtonConvergesQuadratically) {
  for (MaterialModel model : {MaterialModel::corotational, MaterialModel::stvk, MaterialModel::mooney_rivlin}) {
    StaticProblem problem;
    problem.mesh = box_mesh({6, 2, 2}, {0.06, 0.01, 0.01});
    problem.material = material_for(model, 100);
    for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n) {
      const auto node = static_cast<std::int32_t>(n);
      if (problem.mesh.nodes[n].x() == 0) problem.fixed.push_back(node);
      if (std::abs(problem.mesh.nodes[n].x() - 0.06) < 1e-12) problem.prescribed.push_back({node, 2, 0.015});
    }
    const StaticSolution s = solve_static(problem);
    ASSERT_TRUE(s.converged) << s.error;
    const std::vector<double>& r = s.residual_history.back();
    ASSERT_GE(r.size(), 3u) << material_name(model);
    // In the last iterations the error squares: log r_{k+1} / log r_k ≈ 2.
    bool quadratic = false;
    for (std::size_t k = 0; k + 1 < r.size(); ++k)
      if (r[k] < 1e-2 && r[k + 1] > 1e-15) quadratic |= std::log(r[k + 1]) / std::log(r[k]) > 1.7;
    EXPECT_TRUE(quadratic) << material_name(model) << " residuals: " << ::testing::PrintToString(r);
    EXPECT_LE(r.back(), 1e-8);
  }
}

/// Tip deflection (m) of a cantilever [0, L] × [0, h]² fixed at x = 0 under a
/// total end load P along −z spread over the end face's nodes.
double cantilever_tip_deflection(int cells_along, int cells_across, MaterialModel model, double load) {
  const double L = 0.1, h = 0.01;
  StaticProblem problem;
  problem.mesh = box_mesh({cells_along, cells_across, cells_across}, {L, h, h});
  problem.material = Material::from_young(model, 1e6, 0.0);
  std::vector<std::int32_t> end;
  for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n) {
    if (problem.mesh.nodes[n].x() == 0) problem.fixed.push_back(static_cast<std::int32_t>(n));
    if (std::abs(problem.mesh.nodes[n].x() - L) < 1e-12) end.push_back(static_cast<std::int32_t>(n));
  }
  // Consistent loads of a uniform traction on the end face's right-triangle grid.
  for (std::int32_t n : end) problem.loads.push_back({n, 2, -load / static_cast<double>(end.size())});
  const StaticSolution s = solve_static(problem);
  EXPECT_TRUE(s.converged) << s.error;
  double mean = 0;
  for (std::int32_t n : end) mean += s.displacements[3 * n + 2];
  return -mean / static_cast<double>(end.size());
}

TEST(StaticSolver, CantileverConvergesToBeamTheoryUnderRefinement) {
  // E = 1 MPa, ν = 0, L = 10 cm, 1 cm square section, P = 1 mN: PL³/3EI with
  // Timoshenko's shear term PL/(κGA), κ = 5/6.
  const double E = 1e6, G = E / 2, L = 0.1, h = 0.01, P = 1e-3, I = h * h * h * h / 12;
  const double expected = P * L * L * L / (3 * E * I) + P * L / (5.0 / 6.0 * G * h * h);
  double previous_error = 1 / 0.65;
  for (int n : {1, 2, 4, 8}) {
    const double tip = cantilever_tip_deflection(10 * n, n, MaterialModel::linear, P);
    EXPECT_LT(tip, expected);  // linear tetrahedra are too stiff in bending
    const double error = std::abs(tip - expected) / expected;
    EXPECT_LT(error, 0.65 * previous_error) << n << " cells across: " << tip << " m vs " << expected;
    previous_error = error;
  }
  EXPECT_LT(previous_error, 0.07);  // 1, 2, 4, 8 cells across: 76 %, 45 %, 18 %, 5.1 %
  // At small load the nonlinear materials agree with the linear one.
  const double linear = cantilever_tip_deflection(20, 2, MaterialModel::linear, P);
  for (MaterialModel model : {MaterialModel::corotational, MaterialModel::stvk})
    EXPECT_NEAR(cantilever_tip_deflection(20, 2, model, P), linear, 2e-3 * linear) << material_name(model);
}

TEST(StaticSolver, ClampedCompressedBlockConvergesUnderRefinement) {
  // A nearly incompressible block bonded to rigid plates, compressed by 20 %:
  // the force bulges the block non-uniformly; it converges as the mesh refines.
  const Vector3d size(0.01, 0.01, 0.01);
  std::vector<double> forces;
  for (int n : {2, 4, 8}) {
    StaticProblem problem;
    problem.mesh = box_mesh({n, n, n}, size);
    problem.material = Material::mooney_rivlin_from_young(1e5, 0.49, 100);
    problem.load_steps = 4;
    for (std::size_t k = 0; k < problem.mesh.nodes.size(); ++k) {
      const auto node = static_cast<std::int32_t>(k);
      if (problem.mesh.nodes[k].z() == 0) problem.fixed.push_back(node);
      if (std::abs(problem.mesh.nodes[k].z() - size.z()) < 1e-12) {
        problem.prescribed.push_back({node, 0, 0});
        problem.prescribed.push_back({node, 1, 0});
        problem.prescribed.push_back({node, 2, -0.2 * size.z()});
      }
    }
    const StaticSolution s = solve_static(problem);
    ASSERT_TRUE(s.converged) << s.error;
    forces.push_back(reaction_z_at(problem, s, size.z()));
  }
  const double change_coarse = std::abs(forces[1] - forces[0]), change_fine = std::abs(forces[2] - forces[1]);
  EXPECT_LT(change_fine, 0.6 * change_coarse) << forces[0] << " " << forces[1] << " " << forces[2];
  EXPECT_LT(change_fine, 0.1 * std::abs(forces[2]));  // 2, 4, 8 cells: −4.28, −3.34, −3.13 N
  EXPECT_LT(forces[2], 0);                            // the top plate pushes the block down
}

/// m³ of the tetrahedra moved by `u`.
double deformed_volume(TetMesh mesh, const Eigen::VectorXd& u) {
  for (std::size_t n = 0; n < mesh.nodes.size(); ++n) mesh.nodes[n] += u.segment<3>(3 * static_cast<Eigen::Index>(n));
  double volume = 0;
  for (const Tetrahedron& t : mesh.tetrahedra) volume += signed_volume(mesh, t);
  return volume;
}

/// A free-standing PSH block (E = 1 MPa, ν = 0.49) squeezed 20 % from the top
/// with its top and bottom free to slide.
StaticProblem squeezed_block(double bulk_modulus) {
  const Vector3d size(0.01, 0.01, 0.01);
  StaticProblem problem;
  problem.mesh = box_mesh({3, 3, 3}, size);
  problem.material = Material::mooney_rivlin_from_young(1e6, 0.49, 100);
  if (bulk_modulus > 0) problem.material.bulk_modulus = bulk_modulus;
  problem.load_steps = 4;
  for (std::size_t k = 0; k < problem.mesh.nodes.size(); ++k) {
    const auto node = static_cast<std::int32_t>(k);
    const Vector3d& p = problem.mesh.nodes[k];
    if (p.z() == 0) problem.prescribed.push_back({node, 2, 0});
    if (std::abs(p.z() - size.z()) < 1e-12) problem.prescribed.push_back({node, 2, -0.2 * size.z()});
    if (p.x() == 0) problem.prescribed.push_back({node, 0, 0});
    if (p.y() == 0) problem.prescribed.push_back({node, 1, 0});
  }
  return problem;
}

TEST(StaticSolver, TablesThreeBulkModulusIsAcceptedAndLosesMoreVolume) {
  // Ogata et al.'s Table 3 prints κ = 4.167e6 Pa; E/(3(1 − 2ν)) gives 1.667e7.
  // Under the same squeeze the softer bulk modulus lets the volume change more.
  const StaticProblem printed = squeezed_block(4.167e6), ours = squeezed_block(0);
  EXPECT_NEAR(ours.material.bulk_modulus, 1.667e7, 1e4);
  EXPECT_NO_THROW(validate(printed));
  const StaticSolution a = solve_static(printed), b = solve_static(ours);
  ASSERT_TRUE(a.converged) << a.error;
  ASSERT_TRUE(b.converged) << b.error;
  const double rest = 1e-6;
  const double change_printed = std::abs(deformed_volume(printed.mesh, a.displacements) / rest - 1);
  const double change_ours = std::abs(deformed_volume(ours.mesh, b.displacements) / rest - 1);
  EXPECT_GT(change_printed, 1.5 * change_ours) << change_printed << " " << change_ours;
  EXPECT_GT(change_ours, 0.0);
}

TEST(StaticSolver, StartingFromTheInitialPressureReachesTheSameEquilibrium) {
  // The paper starts every pressure at 300 Pa; the solution does not depend on it.
  StaticProblem from_zero = squeezed_block(0), from_300 = squeezed_block(0);
  from_300.initial_pressure = 300;
  const StaticSolution a = solve_static(from_zero), b = solve_static(from_300);
  ASSERT_TRUE(a.converged && b.converged) << a.error << b.error;
  EXPECT_LT((a.displacements - b.displacements).lpNorm<Eigen::Infinity>(), 1e-9 * 0.002);
  EXPECT_LT((a.pressures - b.pressures).lpNorm<Eigen::Infinity>(), 1e-6 * a.pressures.lpNorm<Eigen::Infinity>());
  from_300.initial_pressure = std::nan("");
  EXPECT_THROW(validate(from_300), std::invalid_argument);
}

TEST(StaticSolver, CutsTheLoadStepWhenOneStepIsTooLarge) {
  StaticProblem problem;
  problem.mesh = box_mesh({6, 2, 2}, {0.06, 0.01, 0.01});
  problem.material = Material::mooney_rivlin_from_young(1e5, 0.49, 10);
  for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n) {
    const auto node = static_cast<std::int32_t>(n);
    if (problem.mesh.nodes[n].x() == 0) problem.fixed.push_back(node);
    if (std::abs(problem.mesh.nodes[n].x() - 0.06) < 1e-12) problem.prescribed.push_back({node, 2, 0.05});
  }
  SolverOptions hurried;  // too few iterations for the whole bend at once, enough for its halves
  hurried.max_iterations = 6;
  const StaticSolution s = solve_static(problem, hurried);
  ASSERT_TRUE(s.converged) << s.error;
  EXPECT_GT(s.step_cuts, 0);
  EXPECT_TRUE(s.displacements.allFinite());
}

TEST(StaticSolver, FailsWithAClearErrorAndNoNaN) {
  StaticProblem problem;
  problem.mesh = box_mesh({2, 2, 2}, {0.01, 0.01, 0.01});
  problem.material = material_for(MaterialModel::stvk);
  // Crush the block to a tenth of a millimetre through its top nodes: the
  // elements invert whatever the step.
  for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n) {
    const auto node = static_cast<std::int32_t>(n);
    if (problem.mesh.nodes[n].z() == 0) problem.fixed.push_back(node);
    if (std::abs(problem.mesh.nodes[n].z() - 0.01) < 1e-12 && problem.mesh.nodes[n].x() == 0)
      problem.prescribed.push_back({node, 2, -0.0199});
  }
  problem.load_steps = 1;
  SolverOptions options;
  options.max_step_cuts = 3;
  const StaticSolution s = solve_static(problem, options);
  EXPECT_FALSE(s.converged);
  EXPECT_NE(s.error.find("load step 1 of 1 failed"), std::string::npos) << s.error;
  EXPECT_TRUE(s.displacements.allFinite());

  StaticProblem floating;  // nothing holds it
  floating.mesh = box_mesh({1, 1, 1}, {0.01, 0.01, 0.01});
  floating.material = material_for(MaterialModel::linear);
  floating.loads.push_back({0, 0, 1.0});
  const StaticSolution f = solve_static(floating);
  EXPECT_FALSE(f.converged);
  EXPECT_NE(f.error.find("singular"), std::string::npos) << f.error;
}

TEST(StaticSolver, ValidationNamesTheField) {
  StaticProblem problem;
  problem.mesh = box_mesh({1, 1, 1}, {0.01, 0.01, 0.01});
  problem.material = material_for(MaterialModel::linear);
  problem.fixed = {0};
  const auto message = [](const StaticProblem& p) -> std::string {
    try {
      validate(p);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "accepted";
  };
  EXPECT_EQ(message(problem), "accepted");
  StaticProblem bad = problem;
  bad.mesh.tetrahedra[2][1] = 99;
  EXPECT_NE(message(bad).find("tetrahedra[2]: node 99 is out of range"), std::string::npos) << message(bad);
  bad = problem;
  bad.prescribed.push_back({0, 1, 0.001});
  EXPECT_NE(message(bad).find("prescribed[0]"), std::string::npos) << message(bad);
  bad = problem;
  bad.loads.push_back({3, 4, 1.0});
  EXPECT_NE(message(bad).find("loads[0]: component"), std::string::npos) << message(bad);
  bad = problem;
  bad.material.poisson_ratio = 0.5;
  EXPECT_NE(message(bad).find("material.poisson_ratio"), std::string::npos) << message(bad);
  bad = problem;
  bad.mesh.nodes[5].y() = std::nan("");
  EXPECT_NE(message(bad).find("nodes[5]"), std::string::npos) << message(bad);
}

}  // namespace
}  // namespace organsim::fem

namespace organsim::fem {
namespace {

TEST(StaticSolver, TopPressHoldsTheNodesNearTheFixedPointAndPressesTheTopDown) {
  const TetMesh mesh = box_mesh({8, 8, 10}, {0.04, 0.04, 0.05});
  const Eigen::Vector3d held(0.02, 0.02, 0.0);  // the middle of the bottom face
  const StaticProblem p = top_press_problem(mesh, held, Material::mooney_rivlin_from_young(1e5, 0.49, 100));
  EXPECT_EQ(p.load_steps, 10);
  EXPECT_EQ(top_press_problem(mesh, held, Material::from_young(MaterialModel::linear, 1e5, 0.45)).load_steps, 1);
  ASSERT_FALSE(p.fixed.empty());
  ASSERT_FALSE(p.prescribed.empty());
  for (const std::int32_t n : p.fixed) EXPECT_LT((mesh.nodes[static_cast<std::size_t>(n)] - held).norm(), 0.010);
  for (const PrescribedDisplacement& d : p.prescribed) {
    EXPECT_EQ(d.component, 2);
    EXPECT_DOUBLE_EQ(d.value, -0.005);  // 10 % of the 50 mm height
    EXPECT_GT(mesh.nodes[static_cast<std::size_t>(d.node)].z(), 0.05 - 0.010 - 1e-12);
  }
  EXPECT_NO_THROW(validate(p));  // no node both held and pressed
  const StaticSolution linear =
      solve_static(top_press_problem(mesh, held, Material::from_young(MaterialModel::linear, 1e5, 0.45)));
  ASSERT_TRUE(linear.converged) << linear.error;
  EXPECT_LT(linear.reaction_prescribed.z(), 0) << "the body pushes back against the press";
}

}  // namespace
}  // namespace organsim::fem

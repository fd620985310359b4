// `organsim fem PROBLEM.json [--json] [--out RESULT.vtu]`: a static FEM solve
// of a problem file (fem_problem_file.h, docs/fem.md) — displacements,
// pressures, Newton iterations, reactions, timings; the deformed mesh with its
// displacement, pressure and stress fields for ParaView.
#include <chrono>
#include <cmath>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "command_line/command_line.h"
#include "fem_problem_file.h"
#include "command_line/model_tuning.h"
#include "organsim/fem/elasticity_system.h"
#include "organsim/mesh_io/mesh_io.h"

namespace organsim::cli {
namespace {

struct FemOptions {
  std::string problem_path;
  bool json = false;
  std::string out_path;
  std::string linear_solver = ModelTuning::default_linear_solver();
  int krylov_iterations = fem::TangentSolverOptions{}.max_krylov_iterations;
};

std::string number(double value) { return fmt::format("{:.17g}", value); }

std::string vector3(const Eigen::Vector3d& v) {
  return "[" + number(v.x()) + "," + number(v.y()) + "," + number(v.z()) + "]";
}

/// The deformed mesh (m) with displacement (m), pressure and Cauchy stress (Pa) and its von Mises value.
void write_result(const fem::StaticProblem& problem, const fem::StaticSolution& solution, const std::string& path) {
  std::vector<bool> none(3 * problem.mesh.nodes.size(), false);
  const fem::ElasticitySystem system(problem.mesh, problem.material, none);
  Eigen::VectorXd state = Eigen::VectorXd::Zero(system.dof_count());
  state.head(solution.displacements.size()) = solution.displacements;
  if (solution.pressures.size()) state.tail(solution.pressures.size()) = solution.pressures;

  mesh_io::FieldMesh mesh;
  mesh_io::DataArray displacement{"displacement", 3, {}}, stress{"stress", 9, {}}, von_mises{"von_mises", 1, {}};
  for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n) {
    const Eigen::Vector3d u = solution.displacements.segment<3>(3 * static_cast<Eigen::Index>(n));
    const Eigen::Vector3d x = problem.mesh.nodes[n] + u;
    mesh.points.push_back({x.x(), x.y(), x.z()});
    displacement.values.insert(displacement.values.end(), {u.x(), u.y(), u.z()});
  }
  for (std::size_t e = 0; e < problem.mesh.tetrahedra.size(); ++e) {
    const auto& t = problem.mesh.tetrahedra[e];
    mesh.tetrahedra.push_back({t[0], t[1], t[2], t[3]});
    const Eigen::Matrix3d sigma = system.cauchy_stress(state, e);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) stress.values.push_back(sigma(i, j));
    const Eigen::Matrix3d deviator = sigma - sigma.trace() / 3 * Eigen::Matrix3d::Identity();
    von_mises.values.push_back(std::sqrt(1.5 * deviator.squaredNorm()));
  }
  mesh.point_data = {displacement};
  mesh.cell_data = {stress, von_mises};
  if (solution.pressures.size())
    mesh.cell_data.push_back(
        {"pressure", 1, {solution.pressures.data(), solution.pressures.data() + solution.pressures.size()}});
  mesh.units = "m";
  mesh_io::write_field_vtu(mesh, path);
}

std::string json_report(const fem::StaticProblem& problem, const fem::StaticSolution& s, double total_seconds) {
  std::ostringstream j;
  j << "{\"converged\":" << (s.converged ? "true" : "false");
  if (!s.converged) j << ",\"error\":" << nlohmann::json(s.error).dump();
  j << ",\"material\":\"" << fem::material_name(problem.material.model) << "\",\"nodes\":" << problem.mesh.nodes.size()
    << ",\"tetrahedra\":" << problem.mesh.tetrahedra.size() << ",\"displacements\":[";
  for (Eigen::Index n = 0; n < s.displacements.size() / 3; ++n)
    j << (n ? "," : "") << vector3(s.displacements.segment<3>(3 * n));
  j << "],\"pressures\":[";
  for (Eigen::Index e = 0; e < s.pressures.size(); ++e) j << (e ? "," : "") << number(s.pressures[e]);
  j << "],\"newton_iterations\":[";
  for (std::size_t i = 0; i < s.newton_iterations.size(); ++i) j << (i ? "," : "") << s.newton_iterations[i];
  j << "],\"residuals\":[";
  for (std::size_t i = 0; i < s.residual_history.size(); ++i) {
    j << (i ? "," : "") << "[";
    for (std::size_t k = 0; k < s.residual_history[i].size(); ++k)
      j << (k ? "," : "") << number(s.residual_history[i][k]);
    j << "]";
  }
  j << "],\"step_cuts\":" << s.step_cuts << ",\"reactions\":" << vector3(s.reaction_fixed + s.reaction_prescribed)
    << ",\"reactions_fixed\":" << vector3(s.reaction_fixed)
    << ",\"reactions_prescribed\":" << vector3(s.reaction_prescribed)
    << ",\"linear_solver\":" << nlohmann::json(s.linear_solver).dump() << ",\"factorizations\":" << s.factorizations
    << ",\"krylov_solves\":" << s.krylov_solves << ",\"krylov_iterations\":" << s.krylov_iterations
    << ",\"time_s\":{\"assembly\":" << number(s.assembly_seconds) << ",\"solve\":" << number(s.solve_seconds)
    << ",\"total\":" << number(total_seconds) << "}}\n";
  return j.str();
}

std::string material_summary(const fem::Material& m) {
  if (m.model == fem::MaterialModel::mooney_rivlin)
    return fmt::format("mooney-rivlin (c1 {:g} Pa, c2 {:g} Pa, bulk modulus {:g} Pa, stabilization {:g})", m.c1, m.c2,
                       m.bulk_modulus, m.stabilization);
  return fmt::format("{} (E {:g} Pa, Poisson {:g})", fem::material_name(m.model), m.young_modulus, m.poisson_ratio);
}

int run_fem(const FemOptions& o) {
  const fem::StaticProblem problem = read_fem_problem(o.problem_path);
  const auto start = std::chrono::steady_clock::now();
  fem::StaticSolution solution;
  try {
    fem::SolverOptions options;
    options.factorization = factorization_factory(o.linear_solver);
    options.tangent.max_krylov_iterations = o.krylov_iterations;
    solution = fem::solve_static(problem, options);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error("'" + o.problem_path + "': " + e.what());
  }
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (solution.converged && !o.out_path.empty()) write_result(problem, solution, o.out_path);

  if (o.json) {
    std::cout << json_report(problem, solution, total);
  } else {
    std::cout << fmt::format("{:<14}{}: {} nodes, {} tetrahedra, {}\n", "problem", o.problem_path,
                             problem.mesh.nodes.size(), problem.mesh.tetrahedra.size(),
                             material_summary(problem.material));
    std::string iterations;
    for (int n : solution.newton_iterations) iterations += (iterations.empty() ? "" : ",") + std::to_string(n);
    std::cout << fmt::format("{:<14}{} after {} load step(s), Newton iterations {}, {} step cut(s)\n", "solve",
                             solution.converged ? "converged" : "failed", solution.newton_iterations.size(), iterations,
                             solution.step_cuts);
    if (solution.displacements.size()) {
      Eigen::Index largest = 0;
      double size = 0;
      for (Eigen::Index n = 0; n < solution.displacements.size() / 3; ++n)
        if (const double d = solution.displacements.segment<3>(3 * n).norm(); d > size) size = d, largest = n;
      std::cout << fmt::format("{:<14}largest {:.6g} mm at node {}\n", "displacement", size * 1e3, largest);
    }
    if (solution.pressures.size())
      std::cout << fmt::format("{:<14}{:.6g} .. {:.6g} Pa\n", "pressure", solution.pressures.minCoeff(),
                               solution.pressures.maxCoeff());
    const Eigen::Vector3d& f = solution.reaction_fixed;
    const Eigen::Vector3d& p = solution.reaction_prescribed;
    std::cout << fmt::format("{:<14}fixed ({:.6g}, {:.6g}, {:.6g}) N, prescribed ({:.6g}, {:.6g}, {:.6g}) N\n",
                             "reactions", f.x(), f.y(), f.z(), p.x(), p.y(), p.z());
    std::cout << fmt::format("{:<14}{} factorization(s), {} GMRES solve(s) with a kept one ({} iterations)\n",
                             "linear solves", solution.factorizations, solution.krylov_solves,
                             solution.krylov_iterations);
    std::cout << fmt::format("{:<14}assembly {:.3f} s, solve {:.3f} s ({}), total {:.3f} s\n", "time",
                             solution.assembly_seconds, solution.solve_seconds, solution.linear_solver, total);
    if (solution.converged && !o.out_path.empty())
      std::cout << fmt::format("{:<14}{} (deformed mesh in m; displacement, stress, von_mises{})\n", "out", o.out_path,
                               solution.pressures.size() ? ", pressure" : "");
  }
  if (!solution.converged) throw std::runtime_error("'" + o.problem_path + "': " + solution.error);
  return 0;
}

}  // namespace

Command add_fem_command(CLI::App& app) {
  auto o = std::make_shared<FemOptions>();
  app.add_option("PROBLEM", o->problem_path, "Problem file (JSON, SI units; docs/fem.md)")->required();
  app.add_flag("--json", o->json,
               "Print one JSON object (converged, displacements, pressures, newton_iterations, reactions, time_s)");
  app.add_option("--out", o->out_path, "Write the deformed mesh with displacement, pressure and stress (.vtu)")
      ->check(CLI::Validator(
          [](std::string& path) -> std::string {
            return path.size() > 4 && path.compare(path.size() - 4, 4, ".vtu") == 0 ? "" : "must end in .vtu";
          },
          "FILE.vtu"));
  add_linear_solver_option(app, o->linear_solver);
  app.add_option("--krylov-iterations", o->krylov_iterations,
                 "GMRES iterations allowed with the last factorization before a tangent is factorized afresh; 0 "
                 "factorizes every Newton iteration's tangent")
      ->check(CLI::Range(0, 200))
      ->capture_default_str();
  return [o] { return run_fem(*o); };
}

}  // namespace organsim::cli

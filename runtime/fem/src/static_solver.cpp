#include "organsim/fem/static_solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "organsim/fem/elasticity_system.h"

namespace organsim::fem {

namespace {

/// The share of the Newton tolerance a step's linear solve may leave in the next residual.
constexpr double kLinearShareOfTolerance = 0.1;

std::string node_name(std::int32_t node) { return "node " + std::to_string(node); }

void require(bool condition, const std::string& message) {
  if (!condition) throw std::invalid_argument(message);
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// The solve's state and the pieces every Newton iteration reuses.
class NewtonSolver {
 public:
  NewtonSolver(const StaticProblem& problem, const SolverOptions& options, StaticSolution& out)
      : problem_(problem),
        options_(options),
        out_(out),
        system_(problem.mesh, problem.material, constraint_mask(problem)),
        tangent_solver_(
            make_factorization(options.factorization,
                               system_.has_pressure() ? MatrixKind::quasi_definite : MatrixKind::positive_definite,
                               SolveUse::preconditioner),
            options.tangent) {
    out_.linear_solver = tangent_solver_.name();
    system_.set_foundation(problem.foundation);
    const Eigen::Index dofs = system_.dof_count(),
                       displacement_dofs = static_cast<Eigen::Index>(3 * problem.mesh.nodes.size());
    x_ = Eigen::VectorXd::Zero(dofs);
    x_.tail(dofs - displacement_dofs).setConstant(problem.initial_pressure);
    gradient_.resize(dofs);
    full_load_ = Eigen::VectorXd::Zero(dofs);
    full_load_.head(displacement_dofs) = system_.body_force(problem.density, problem.gravity);
    for (const NodalLoad& load : problem.loads) full_load_[3 * load.node + load.component] += load.value;
    full_prescribed_ = Eigen::VectorXd::Zero(system_.constrained_count());
    for (const PrescribedDisplacement& p : problem.prescribed)
      full_prescribed_[-1 - system_.free_index()[static_cast<std::size_t>(3 * p.node + p.component)]] = p.value;
    // Pressure rows (m³) enter the residual norm as forces: times κ / h̄.
    row_scale_ = Eigen::VectorXd::Ones(system_.free_count());
    displacement_rows_ = Eigen::VectorXd::Ones(system_.free_count());
    const double pressure_scale = system_.has_pressure() ? problem.material.bulk_modulus / system_.mean_diameter() : 1;
    for (Eigen::Index d = displacement_dofs; d < dofs; ++d) {
      const std::int32_t row = system_.free_index()[static_cast<std::size_t>(d)];
      row_scale_[row] = pressure_scale;
      displacement_rows_[row] = 0;
    }
    const Material& m = problem.material;
    const double modulus = std::max({m.young_modulus, m.c1 + m.c2, m.bulk_modulus});
    step_limit_ = 10 * bounding_box_size(problem.mesh.nodes).norm();
    residual_floor_ = 1e-13 * modulus * system_.mean_diameter() * system_.mean_diameter() *
                      std::sqrt(static_cast<double>(system_.free_count()));
  }

  void solve() {
    const int steps = problem_.load_steps;
    double done = 0;  // load factor reached
    for (int step = 1; step <= steps; ++step) {
      const double target = static_cast<double>(step) / steps;
      double increment = target - done;
      int cuts = 0, iterations = 0;
      while (done < target) {
        const double next = std::min(target, done + increment);
        const Eigen::VectorXd saved = x_;
        int used = 0;
        std::string failure;
        if (increment_load(done, next, used, failure)) {
          done = next;
          iterations += used;
          continue;
        }
        x_ = saved;
        tangent_solver_.refactorize_next();
        iterations += used;
        if (++cuts > options_.max_step_cuts) {
          out_.error = "load step " + std::to_string(step) + " of " + std::to_string(steps) + " failed after " +
                       std::to_string(options_.max_step_cuts) + " halvings: " + failure +
                       "; try more load steps or smaller prescribed displacements";
          out_.newton_iterations.push_back(iterations);
          finish(done);
          return;
        }
        ++out_.step_cuts;
        increment *= 0.5;
      }
      out_.newton_iterations.push_back(iterations);
    }
    out_.converged = true;
    finish(1.0);
  }

 private:
  static std::vector<bool> constraint_mask(const StaticProblem& problem) {
    std::vector<bool> mask(3 * problem.mesh.nodes.size(), false);
    for (std::int32_t n : problem.fixed)
      for (int c = 0; c < 3; ++c) mask[static_cast<std::size_t>(3 * n + c)] = true;
    for (const PrescribedDisplacement& p : problem.prescribed)
      mask[static_cast<std::size_t>(3 * p.node + p.component)] = true;
    return mask;
  }

  /// The free rows of ∂Π/∂x − F_ext(s) at the current state (after assemble).
  void free_residual(double load_factor, Eigen::VectorXd& residual) const {
    residual.resize(system_.free_count());
    const auto& index = system_.free_index();
    for (std::size_t d = 0; d < index.size(); ++d)
      if (index[d] >= 0)
        residual[index[d]] =
            gradient_[static_cast<Eigen::Index>(d)] - load_factor * full_load_[static_cast<Eigen::Index>(d)];
  }

  double scaled_norm(const Eigen::VectorXd& residual) const { return residual.cwiseProduct(row_scale_).norm(); }

  /// Newton from load factor `from` (converged) to `to`. False with `failure` set when it fails.
  bool increment_load(double from, double to, int& iterations, std::string& failure) {
    const Eigen::VectorXd constrained_step = (to - from) * full_prescribed_;
    const auto& index = system_.free_index();
    std::vector<double> history;
    double first = 0;
    for (int iteration = 0; iteration <= options_.max_iterations; ++iteration) {
      auto start = std::chrono::steady_clock::now();
      const std::int64_t inverted = system_.assemble(x_, gradient_, true);
      out_.assembly_seconds += seconds_since(start);
      if (inverted >= 0) {
        failure = "tetrahedron " + std::to_string(inverted) + " inverted (J ≤ 0)";
        out_.residual_history.push_back(history);
        return false;
      }
      free_residual(to, residual_);
      if (iteration == 0) residual_ += system_.tangent_coupling() * constrained_step;
      const double norm = scaled_norm(residual_);
      if (!std::isfinite(norm)) {
        failure = "the residual is not finite";
        out_.residual_history.push_back(history);
        return false;
      }
      if (iteration == 0) {
        first = std::max(norm, residual_floor_);
      } else {
        history.push_back(norm / first);
        if (norm <= problem_.tolerance * first || norm <= residual_floor_) {
          out_.residual_history.push_back(history);
          return true;
        }
        if (iteration == options_.max_iterations) break;
      }
      start = std::chrono::steady_clock::now();
      residual_ = -residual_;
      // A step solved to relative accuracy η leaves about η × norm of this
      // residual in the next one: η = 0.1 tolerance × first / norm keeps that
      // under a tenth of what the criterion accepts, so Newton needs no more
      // iterations, and the last iteration of an increment stops GMRES early.
      const double sufficient_accuracy = kLinearShareOfTolerance * problem_.tolerance * first / norm;
      const bool factorized = tangent_solver_.solve(system_.tangent_free(), residual_, step_, sufficient_accuracy);
      out_.solve_seconds += seconds_since(start);
      out_.factorizations = tangent_solver_.factorizations();
      out_.krylov_solves = tangent_solver_.krylov_solves();
      out_.krylov_iterations = tangent_solver_.krylov_iterations();
      out_.analysis_seconds = tangent_solver_.analysis_seconds();
      // No Newton step of a held body moves a node by more than ten times the
      // body's size; one that does solved a singular system.
      if (!factorized || !step_.allFinite() ||
          step_.cwiseAbs().cwiseProduct(displacement_rows_).maxCoeff() > step_limit_) {
        failure = "the tangent stiffness is singular (is the body held by fixed or prescribed nodes?)";
        out_.residual_history.push_back(history);
        return false;
      }
      ++iterations;
      for (std::size_t d = 0; d < index.size(); ++d) {
        const std::int32_t i = index[d];
        if (i >= 0)
          x_[static_cast<Eigen::Index>(d)] += step_[i];
        else if (iteration == 0)
          x_[static_cast<Eigen::Index>(d)] += constrained_step[-1 - i];
      }
    }
    failure = "Newton did not reach the tolerance in " + std::to_string(options_.max_iterations) + " iterations";
    out_.residual_history.push_back(history);
    return false;
  }

  void finish(double load_factor) {
    const Eigen::Index displacement_dofs = static_cast<Eigen::Index>(3 * problem_.mesh.nodes.size());
    out_.displacements = x_.head(displacement_dofs);
    if (system_.has_pressure()) out_.pressures = x_.tail(system_.dof_count() - displacement_dofs);
    out_.nodal_reactions = Eigen::VectorXd::Zero(displacement_dofs);
    if (system_.assemble(x_, gradient_, false) >= 0) return;
    std::vector<bool> fixed(problem_.mesh.nodes.size(), false);
    for (std::int32_t n : problem_.fixed) fixed[static_cast<std::size_t>(n)] = true;
    const auto& index = system_.free_index();
    for (Eigen::Index d = 0; d < displacement_dofs; ++d) {
      if (index[static_cast<std::size_t>(d)] >= 0) continue;
      const double reaction = gradient_[d] - load_factor * full_load_[d];
      out_.nodal_reactions[d] = reaction;
      (fixed[static_cast<std::size_t>(d / 3)] ? out_.reaction_fixed : out_.reaction_prescribed)[d % 3] += reaction;
    }
  }

  const StaticProblem& problem_;
  const SolverOptions& options_;
  StaticSolution& out_;
  ElasticitySystem system_;
  Eigen::VectorXd x_, gradient_, full_load_, full_prescribed_, row_scale_, displacement_rows_, residual_, step_;
  double residual_floor_ = 0, step_limit_ = 0;
  TangentSolver tangent_solver_;
};

}  // namespace

void validate(const StaticProblem& problem) {
  const std::size_t nodes = problem.mesh.nodes.size();
  require(nodes >= 4, "nodes: a problem needs at least 4 nodes");
  require(!problem.mesh.tetrahedra.empty(), "tetrahedra: a problem needs at least one tetrahedron");
  for (std::size_t n = 0; n < nodes; ++n)
    require(problem.mesh.nodes[n].allFinite(), "nodes[" + std::to_string(n) + "]: not a finite number");
  for (std::size_t e = 0; e < problem.mesh.tetrahedra.size(); ++e) {
    const Tetrahedron& t = problem.mesh.tetrahedra[e];
    for (std::int32_t n : t)
      require(n >= 0 && static_cast<std::size_t>(n) < nodes, "tetrahedra[" + std::to_string(e) + "]: node " +
                                                                 std::to_string(n) + " is out of range (0.." +
                                                                 std::to_string(nodes - 1) + ")");
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b)
        require(t[static_cast<std::size_t>(a)] != t[static_cast<std::size_t>(b)],
                "tetrahedra[" + std::to_string(e) + "]: a node appears twice");
  }
  const Material& m = problem.material;
  if (m.model == MaterialModel::mooney_rivlin) {
    require(std::isfinite(m.c1) && std::isfinite(m.c2) && m.c1 >= 0 && m.c2 >= 0 && m.c1 + m.c2 > 0,
            "material: c1 and c2 must be finite, ≥ 0 and not both 0 (Pa)");
    require(std::isfinite(m.bulk_modulus) && m.bulk_modulus > 0, "material.bulk_modulus: must be finite and > 0 (Pa)");
    require(std::isfinite(m.stabilization) && m.stabilization >= 0, "material.stabilization: must be finite and ≥ 0");
  } else {
    require(std::isfinite(m.young_modulus) && m.young_modulus > 0,
            "material.young_modulus: must be finite and > 0 (Pa)");
    require(std::isfinite(m.poisson_ratio) && m.poisson_ratio > -1 && m.poisson_ratio < 0.5,
            "material.poisson_ratio: must be in (−1, 0.5)");
  }
  require(std::isfinite(problem.density) && problem.density >= 0, "density: must be finite and ≥ 0 (kg/m³)");
  require(problem.gravity.allFinite(), "gravity: not a finite vector");
  require(std::isfinite(problem.initial_pressure), "initial_pressure: not a finite number (Pa)");
  std::vector<bool> constrained(3 * nodes, false);
  for (std::size_t i = 0; i < problem.fixed.size(); ++i) {
    const std::int32_t n = problem.fixed[i];
    require(n >= 0 && static_cast<std::size_t>(n) < nodes, "fixed[" + std::to_string(i) + "]: node out of range");
    for (int c = 0; c < 3; ++c) constrained[static_cast<std::size_t>(3 * n + c)] = true;
  }
  // A prescribed displacement and a nodal load name the same things: node, component, value.
  const auto check_component = [&](const char* field, std::size_t i, std::int32_t node, int component, double value) {
    const std::string where = std::string(field) + "[" + std::to_string(i) + "]: ";
    require(node >= 0 && static_cast<std::size_t>(node) < nodes, where + "node out of range");
    require(component >= 0 && component <= 2, where + "component must be 0, 1 or 2");
    require(std::isfinite(value), where + "value is not a finite number");
    return where;
  };
  for (std::size_t i = 0; i < problem.prescribed.size(); ++i) {
    const PrescribedDisplacement& p = problem.prescribed[i];
    const std::string where = check_component("prescribed", i, p.node, p.component, p.value);
    const auto dof = static_cast<std::size_t>(3 * p.node + p.component);
    require(!constrained[dof], where + node_name(p.node) + " component " + std::to_string(p.component) +
                                   " is already fixed or prescribed");
    constrained[dof] = true;
  }
  for (std::size_t i = 0; i < problem.loads.size(); ++i)
    check_component("loads", i, problem.loads[i].node, problem.loads[i].component, problem.loads[i].value);
  for (std::size_t i = 0; i < problem.foundation.size(); ++i) {
    const FoundationSpring& s = problem.foundation[i];
    const std::string where = "foundation[" + std::to_string(i) + "]: ";
    require(s.node >= 0 && static_cast<std::size_t>(s.node) < nodes, where + "node out of range");
    require(std::isfinite(s.stiffness) && s.stiffness > 0, where + "the stiffness must be finite and > 0 (N/m)");
    require(!s.unilateral || (s.normal.allFinite() && std::abs(s.normal.norm() - 1.0) < 1e-9),
            where + "the normal must be a unit vector");
  }
  require(problem.load_steps >= 1 && problem.load_steps <= 100000, "load_steps: must be between 1 and 100000");
  require(std::isfinite(problem.tolerance) && problem.tolerance > 0 && problem.tolerance < 1,
          "tolerance: must be in (0, 1)");
}

StaticProblem top_press_problem(TetMesh mesh, const Eigen::Vector3d& fixed_point, const Material& material) {
  constexpr double kReach = 0.010;  // m
  StaticProblem p;
  p.mesh = std::move(mesh);
  p.material = material;
  p.load_steps = material.model == MaterialModel::linear ? 1 : 10;
  std::size_t top = 0;
  for (std::size_t n = 0; n < p.mesh.nodes.size(); ++n)
    if (p.mesh.nodes[n].z() > p.mesh.nodes[top].z()) top = n;
  const double press = 0.1 * bounding_box_size(p.mesh.nodes).z();
  for (std::size_t n = 0; n < p.mesh.nodes.size(); ++n) {
    const auto node = static_cast<std::int32_t>(n);
    if ((p.mesh.nodes[n] - fixed_point).norm() < kReach)
      p.fixed.push_back(node);
    else if ((p.mesh.nodes[n] - p.mesh.nodes[top]).norm() < kReach)
      p.prescribed.push_back({node, 2, -press});
  }
  return p;
}

StaticSolution solve_static(const StaticProblem& problem, const SolverOptions& options) {
  validate(problem);
  StaticSolution solution;
  NewtonSolver solver(problem, options, solution);
  solver.solve();
  return solution;
}

}  // namespace organsim::fem

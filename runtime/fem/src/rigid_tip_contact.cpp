#include "organsim/fem/rigid_tip_contact.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <unordered_map>

#include <Eigen/Dense>

#include "organsim/fem/elasticity_system.h"

namespace organsim::fem {
namespace {

constexpr int kMostPasses = 1000;

void check(const ContactProblem& p, const RigidTip& tip) {
  if (p.material.model != MaterialModel::linear)
    throw std::invalid_argument("press_rigid_tip: only the linear material (small strain) is supported");
  if (!(tip.radius > 0.0) || !std::isfinite(tip.radius))
    throw std::invalid_argument("press_rigid_tip: the tip's radius must be positive");
  if (!tip.centre.allFinite() || !(std::abs(tip.axis.norm() - 1.0) < 1e-9))
    throw std::invalid_argument("press_rigid_tip: the tip's centre must be finite and its axis a unit vector");
  const auto nodes = static_cast<std::int32_t>(p.mesh.nodes.size());
  auto in_range = [&](std::int32_t n) { return n >= 0 && n < nodes; };
  for (const std::int32_t n : p.fixed)
    if (!in_range(n)) throw std::invalid_argument("press_rigid_tip: a fixed node is out of range");
  for (const std::int32_t n : p.candidates)
    if (!in_range(n)) throw std::invalid_argument("press_rigid_tip: a candidate node is out of range");
  for (const PrescribedDisplacement& r : p.rollers)
    if (!in_range(r.node) || r.component < 0 || r.component > 2 || r.value != 0.0)
      throw std::invalid_argument("press_rigid_tip: a roller must name a node and a component, with the value 0");
}

}  // namespace

double RigidTip::gap(const Eigen::Vector3d& y, Eigen::Vector3d& normal) const noexcept {
  if (shape == Shape::sphere) {
    const Eigen::Vector3d from_centre = y - centre;
    const double distance = from_centre.norm();
    normal = distance > 0.0 ? Eigen::Vector3d(from_centre / distance) : Eigen::Vector3d(axis);
    return distance - radius;
  }
  normal = axis;
  const Eigen::Vector3d from_centre = y - centre;
  const double along = from_centre.dot(axis);
  if ((from_centre - along * axis).norm() > radius) return std::numeric_limits<double>::infinity();
  return along;
}

ContactSolution press_rigid_tip(const ContactProblem& problem, const RigidTip& tip, FactorizationFactory factory) {
  check(problem, tip);
  const TetMesh& mesh = problem.mesh;
  const std::size_t nodes = mesh.nodes.size();
  std::vector<bool> constrained(3 * nodes, false);
  for (const std::int32_t n : problem.fixed)
    for (int c = 0; c < 3; ++c) constrained[3 * static_cast<std::size_t>(n) + c] = true;
  for (const PrescribedDisplacement& r : problem.rollers)
    constrained[3 * static_cast<std::size_t>(r.node) + r.component] = true;

  ElasticitySystem system(mesh, problem.material, constrained);
  Eigen::VectorXd gradient(system.dof_count());
  system.assemble(Eigen::VectorXd::Zero(system.dof_count()), gradient, true);
  std::unique_ptr<Factorization> factor = make_factorization(factory, MatrixKind::positive_definite, SolveUse::newton);
  factor->analyze(system.tangent_free());
  ContactSolution solution;
  solution.displacements = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(3 * nodes));
  if (!factor->factorize(system.tangent_free())) {
    solution.error = "the stiffness is singular: the body is not held (give fixed nodes)";
    return solution;
  }
  const std::vector<std::int32_t>& free_of = system.free_index();

  std::vector<std::int32_t> candidates = problem.candidates;
  if (candidates.empty())
    for (std::size_t n = 0; n < nodes; ++n) candidates.push_back(static_cast<std::int32_t>(n));
  std::sort(candidates.begin(), candidates.end());
  candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
  const auto c_count = static_cast<Eigen::Index>(candidates.size());
  std::vector<std::int32_t> slot(nodes, -1);  // node → its place among the candidates
  for (Eigen::Index k = 0; k < c_count; ++k)
    slot[static_cast<std::size_t>(candidates[static_cast<std::size_t>(k)])] = static_cast<std::int32_t>(k);

  // Only the candidates' displacements matter until the end: K⁻¹ restricted
  // to their rows and an active node's three columns is kept per node, so a
  // node costs one three-column solve however often the set changes.
  std::unordered_map<std::int32_t, Eigen::MatrixX3d> columns;
  Eigen::MatrixX3d unit(system.free_count(), 3), response(system.free_count(), 3);
  auto columns_of = [&](std::int32_t n) -> const Eigen::MatrixX3d& {
    auto [at, inserted] = columns.try_emplace(n);
    if (!inserted) return at->second;
    unit.setZero();
    for (int c = 0; c < 3; ++c) {
      const std::int32_t f = free_of[3 * static_cast<std::size_t>(n) + c];
      if (f >= 0) unit(f, c) = 1.0;
    }
    factor->solve3(unit, response);
    at->second.setZero(3 * c_count, 3);
    for (Eigen::Index k = 0; k < c_count; ++k)
      for (int c = 0; c < 3; ++c) {
        const std::int32_t f = free_of[3 * static_cast<std::size_t>(candidates[static_cast<std::size_t>(k)]) + c];
        if (f >= 0) at->second.row(3 * k + c) = response.row(f);
      }
    return at->second;
  };

  Eigen::VectorXd u_candidates = Eigen::VectorXd::Zero(3 * c_count);  // m, 3 per candidate
  // Candidate k's gap to the tip (m) and the tip's normal there, by the
  // problem's kinematics.
  auto gap_of = [&](Eigen::Index k, Eigen::Vector3d& normal) {
    const Eigen::Vector3d& x = mesh.nodes[static_cast<std::size_t>(candidates[static_cast<std::size_t>(k)])];
    const Eigen::Vector3d u = u_candidates.segment<3>(3 * k);
    if (problem.kinematics == ContactKinematics::finite) return tip.gap(x + u, normal);
    const Eigen::Vector3d from_centre = x - tip.centre;
    const double across = (from_centre - from_centre.dot(tip.axis) * tip.axis).norm();
    normal = tip.axis;
    if (across > tip.radius) return std::numeric_limits<double>::infinity();
    const double face = tip.shape == RigidTip::Shape::sphere
                            ? std::sqrt(tip.radius * tip.radius - across * across)
                            : 0.0;  // how far the tip's front reaches beyond its centre along the axis
    return (from_centre + u).dot(tip.axis) - face;
  };
  // A node joins when it lies inside the tip by more than this; it is
  // numerical noise below (m).
  const double tolerance = 1e-9 * tip.radius;
  std::vector<Eigen::Index> active;  // places among the candidates
  Eigen::Vector3d normal;
  for (Eigen::Index k = 0; k < c_count; ++k)
    if (gap_of(k, normal) < -tolerance) active.push_back(k);

  Eigen::VectorXd lambda;
  std::vector<Eigen::Vector3d> normals;
  for (solution.iterations = 1; solution.iterations <= kMostPasses; ++solution.iterations) {
    const Eigen::Index m = static_cast<Eigen::Index>(active.size());
    // W = K⁻¹ N at the candidates, one column per active node; b from the
    // constraint linearized at the current displacements.
    Eigen::MatrixXd w(3 * c_count, m);
    Eigen::VectorXd b(m);
    normals.assign(static_cast<std::size_t>(m), Eigen::Vector3d::Zero());
    for (Eigen::Index j = 0; j < m; ++j) {
      const Eigen::Index k = active[static_cast<std::size_t>(j)];
      Eigen::Vector3d& nj = normals[static_cast<std::size_t>(j)];
      const double gap = gap_of(k, nj);
      b[j] = nj.dot(u_candidates.segment<3>(3 * k)) - gap;
      w.col(j) = columns_of(candidates[static_cast<std::size_t>(k)]) * nj;
    }
    Eigen::MatrixXd s(m, m);
    for (Eigen::Index i = 0; i < m; ++i)
      s.row(i) =
          normals[static_cast<std::size_t>(i)].transpose() * w.middleRows<3>(3 * active[static_cast<std::size_t>(i)]);
    lambda = s.ldlt().solve(b);
    const Eigen::VectorXd before = u_candidates;
    u_candidates = w * lambda;

    // Nodes that pull leave (the most negative first: one at a time keeps the
    // set from oscillating); nodes inside the tip join.
    bool changed = false;
    if (m > 0) {
      const Eigen::Index most_pulling = std::min_element(lambda.data(), lambda.data() + m) - lambda.data();
      if (lambda[most_pulling] < 0.0) {
        active.erase(active.begin() + most_pulling);
        changed = true;
      }
    }
    std::vector<Eigen::Index> sorted = active;
    std::sort(sorted.begin(), sorted.end());
    for (Eigen::Index k = 0; k < c_count; ++k)
      if (!std::binary_search(sorted.begin(), sorted.end(), k) && gap_of(k, normal) < -tolerance) {
        active.push_back(k);
        changed = true;
      }
    const double moved = (u_candidates - before).lpNorm<Eigen::Infinity>();
    if (changed || moved > 1e-9 * tip.radius) continue;

    // Settled: the whole field from one solve with the contact forces.
    Eigen::VectorXd load = Eigen::VectorXd::Zero(system.free_count()), free_u(system.free_count());
    for (Eigen::Index j = 0; j < m; ++j) {
      const std::int32_t n = candidates[static_cast<std::size_t>(active[static_cast<std::size_t>(j)])];
      solution.active.push_back(n);
      solution.force -= lambda[j] * normals[static_cast<std::size_t>(j)];
      for (int c = 0; c < 3; ++c) {
        const std::int32_t f = free_of[3 * static_cast<std::size_t>(n) + c];
        if (f >= 0) load[f] += lambda[j] * normals[static_cast<std::size_t>(j)][c];
      }
    }
    if (m > 0) factor->solve(load, free_u);
    for (std::size_t d = 0; d < 3 * nodes; ++d)
      solution.displacements[static_cast<Eigen::Index>(d)] = m > 0 && free_of[d] >= 0 ? free_u[free_of[d]] : 0.0;
    solution.converged = true;
    return solution;
  }
  solution.error = "the contact's active set did not settle within " + std::to_string(kMostPasses) + " passes";
  return solution;
}

}  // namespace organsim::fem

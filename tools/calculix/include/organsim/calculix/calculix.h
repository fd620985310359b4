// CalculiX (Debian calculix-ccx) as the independent reference solver of the
// FEM models: a static problem written as a ccx input deck on the same C3D4
// mesh (linear tetrahedra, one integration point: the same discretization as
// our P1 elements), solved by `ccx`, its displacements read back.
//   linear         *ELASTIC, no NLGEOM
//   stvk           *ELASTIC with NLGEOM (ccx's elastic law under NLGEOM is S = C : E)
//   mooney-rivlin  *HYPERELASTIC, MOONEY-RIVLIN with D1 = 2/κ and NLGEOM (our P1/P0
//                  pressure without stabilization is p = κ (J − 1) element by
//                  element: ccx's volumetric energy (J − 1)²/D1)
// The co-rotational and stabilized models have no ccx counterpart.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "organsim/fem/static_solver.h"

namespace organsim::calculix {

/// A material point or patch of the mesh moved by a prescribed displacement:
/// the combination Σ wᵢ uᵢ of `nodes` with `weights` (a point's barycentric
/// weights on a face's nodes, or a grasped patch's area weights; a weight 0
/// leaves a node out) is held at `displacement` (m), as a grasp holds its
/// patch. In the deck: a node of its own held at the displacement (*BOUNDARY)
/// and tied to the point, Σ wᵢ uᵢ − u = 0 per component (*EQUATION).
struct PointDisplacement {
  std::vector<std::int32_t> nodes;
  std::vector<double> weights;
  Eigen::Vector3d displacement = Eigen::Vector3d::Zero();
};

/// What ccx gave: the displacements (3 per node, m) and the force the
/// prescribed points take, summed (N, applied to the organ there: the
/// internal forces of their faces' free nodes, which only the points load).
struct Solution {
  Eigen::VectorXd displacements;
  Eigen::Vector3d point_force = Eigen::Vector3d::Zero();
};

/// Writes `problem`, with `points` held, as a ccx input deck (node and
/// element numbers 1-based). Throws std::invalid_argument for a material ccx
/// cannot take, or a point whose nodes are all clamped or tied to another
/// point already.
void write_deck(const fem::StaticProblem& problem, const std::filesystem::path& path,
                const std::vector<PointDisplacement>& points = {});

/// Solves `problem` with ccx in a scratch directory (removed afterwards unless
/// ccx fails) and returns the displacements (3 per node, m). Throws
/// std::runtime_error naming the log when ccx fails or is missing.
Eigen::VectorXd solve(const fem::StaticProblem& problem, const std::string& job_name);
/// The same with `points` held at their displacements, and their force.
Solution solve(const fem::StaticProblem& problem, const std::string& job_name,
               const std::vector<PointDisplacement>& points);

}  // namespace organsim::calculix

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

#include <filesystem>
#include <string>

#include <Eigen/Core>

#include "organsim/fem/static_solver.h"

namespace organsim::calculix {

/// Writes `problem` as a ccx input deck (node and element numbers 1-based).
/// Throws std::invalid_argument for a material ccx cannot take.
void write_deck(const fem::StaticProblem& problem, const std::filesystem::path& path);

/// Solves `problem` with ccx in a scratch directory (removed afterwards unless
/// ccx fails) and returns the displacements (3 per node, m). Throws
/// std::runtime_error naming the log when ccx fails or is missing.
Eigen::VectorXd solve(const fem::StaticProblem& problem, const std::string& job_name);

}  // namespace organsim::calculix

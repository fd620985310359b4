// Static equilibrium of a tetrahedral FEM problem (docs/fem.md): fixed nodes,
// prescribed displacement components, nodal loads and a dead body force ρg,
// applied in load steps, each solved by Newton–Raphson on the
// ElasticitySystem to the paper's criterion ‖F − Q‖ / ‖F − Q‖_first ≤ tolerance.
//
// Prescribed displacements enter each load step through a consistent
// predictor: the step's increment ΔūC of the constrained components is pushed
// through the tangent (K_ff Δu_f = −(r_f + K_fc Δū_c)) rather than moving
// those nodes alone, which on a nearly incompressible body would invert the
// elements next to them. A load step that fails (no convergence within the
// iteration limit, an inverted element, a non-finite value) is undone and
// retried in halves; when halving no longer helps the solve stops with an
// error that names the cause and the tetrahedron — never with NaN.
//
// The linear solver factorizes the free–free block of the Hessian
// (factorization.h): symmetric positive definite for the displacement-only
// materials near equilibrium, symmetric quasi-definite ([K_uu G; Gᵀ −C], K_uu
// and C positive definite) for mooney-rivlin; quasi-definite matrices have an
// LDLᵀ factorization for every symmetric ordering, with no pivoting
// (docs/fem.md compares the factorizations with the alternatives). The
// factorization is kept while GMRES preconditioned with it solves the later
// iterations' systems in a few steps (tangent_solver.h).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "organsim/fem/elasticity_system.h"
#include "organsim/fem/factorization.h"
#include "organsim/fem/material.h"
#include "organsim/fem/tangent_solver.h"
#include "organsim/fem/tet_mesh.h"

namespace organsim::fem {

struct PrescribedDisplacement {
  std::int32_t node = 0;
  int component = 0;  ///< 0: x, 1: y, 2: z
  double value = 0;   ///< m, reached at the last load step
};

struct NodalLoad {
  std::int32_t node = 0;
  int component = 0;
  double value = 0;  ///< N, reached at the last load step
};

struct StaticProblem {
  TetMesh mesh;
  Material material;
  double density = 0;                                 ///< kg/m³
  Eigen::Vector3d gravity = Eigen::Vector3d::Zero();  ///< m/s² (dead load ρg, scaled with the load steps)
  std::vector<std::int32_t> fixed;                    ///< nodes held in all three components
  std::vector<PrescribedDisplacement> prescribed;
  std::vector<NodalLoad> loads;
  /// Nodes held elastically by what surrounds the body (docs/supports.md).
  std::vector<FoundationSpring> foundation;
  int load_steps = 1;
  double tolerance = 1e-8;  ///< on ‖F − Q‖ / ‖F − Q‖_first
  /// Pa: where Newton's iteration starts every tetrahedron's pressure
  /// (mooney-rivlin; Ogata et al. start at 300 Pa, "λ = initial pressure").
  double initial_pressure = 0;
};

/// Throws std::invalid_argument with a one-line message naming the field or
/// element at fault (an index out of range, a non-finite number, a material
/// constant out of range, a node both fixed and prescribed, …). The
/// tetrahedra's volumes are checked when the system is built.
void validate(const StaticProblem& problem);

struct SolverOptions {
  int max_iterations = 25;  ///< Newton iterations per load increment
  int max_step_cuts = 10;   ///< halvings of one load step before giving up
  /// The tangent's factorization (null: Eigen's simplicial LDLᵀ).
  FactorizationFactory factorization = nullptr;
  /// When a tangent is factorized afresh and when GMRES reuses the last factorization.
  TangentSolverOptions tangent;
};

struct StaticSolution {
  bool converged = false;
  std::string error;                   ///< one line when not converged
  Eigen::VectorXd displacements;       ///< 3 per node, m
  Eigen::VectorXd pressures;           ///< per tetrahedron, Pa (mooney-rivlin; else empty)
  std::vector<int> newton_iterations;  ///< per load step (its increments' iterations summed)
  /// Per Newton iteration of every increment: ‖F − Q‖ / ‖F − Q‖_first after it.
  std::vector<std::vector<double>> residual_history;
  /// The forces the supports exert on the body (N, 3 per node; 0 on free
  /// components), and their sums over the fixed nodes and over the prescribed
  /// components (with no other load, fixed + prescribed = − the body force).
  Eigen::VectorXd nodal_reactions;
  Eigen::Vector3d reaction_fixed = Eigen::Vector3d::Zero(), reaction_prescribed = Eigen::Vector3d::Zero();
  int step_cuts = 0;
  /// Newton systems solved: by a fresh factorization, and by GMRES with the
  /// kept one; GMRES iterations run (one solve with the factor each).
  int factorizations = 0, krylov_solves = 0, krylov_iterations = 0;
  double assembly_seconds = 0, solve_seconds = 0;
  double analysis_seconds = 0;  ///< the pattern's ordering and analysis, part of solve_seconds
  std::string linear_solver;    ///< the factorization's name
};

/// The press the FEM experiments and benchmarks apply to an organ's
/// tetrahedra (fem_paper, fem_bench PshPress): the nodes within 10 mm of
/// `fixed_point` held (as the beam model is clamped), those within 10 mm of the
/// topmost node moved down by 10 % of the mesh's height, in 10 load steps (one
/// for the linear material).
StaticProblem top_press_problem(TetMesh mesh, const Eigen::Vector3d& fixed_point, const Material& material);

/// Validates and solves `problem`. Errors of the input throw
/// std::invalid_argument; a solve that fails returns converged = false with
/// `error` set and the last converged state.
StaticSolution solve_static(const StaticProblem& problem, const SolverOptions& options = {});

}  // namespace organsim::fem

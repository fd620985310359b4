// Fuzz target for the `organsim fem` problem reader. Every input must either be
// refused with the reader's one-line std::runtime_error or give a problem that
// validates; small accepted problems are also solved, and a solve must end
// converged with finite fields, or not converged with its error said — never
// NaN, never another exception.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "fem_problem_file.h"

namespace {

bool finite(const Eigen::VectorXd& values) { return values.allFinite(); }

void solve_small(const organsim::fem::StaticProblem& problem) {
  // Bounded work per input: a few elements and steps, few Newton iterations.
  if (problem.mesh.nodes.size() > 32 || problem.mesh.tetrahedra.size() > 48 || problem.load_steps > 4) return;
  organsim::fem::SolverOptions options;
  options.max_iterations = 8;
  options.max_step_cuts = 3;
  organsim::fem::StaticSolution solution;
  try {
    solution = organsim::fem::solve_static(problem, options);
  } catch (const std::invalid_argument&) {
    return;  // an input error found when the system is built (e.g. a flat tetrahedron)
  }
  if (solution.converged) {
    if (!finite(solution.displacements) || !finite(solution.pressures) || !finite(solution.nodal_reactions))
      std::abort();
  } else if (solution.error.empty()) {
    std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  organsim::fem::StaticProblem problem;
  try {
    problem = organsim::cli::parse_fem_problem(text);
  } catch (const std::runtime_error& error) {
    if (std::string(error.what()).empty()) std::abort();
    return 0;
  }
  solve_small(problem);
  return 0;
}

// The `organsim fem` problem file (docs/fem.md): one JSON object in SI units,
//   { "nodes": [[x, y, z], ...], "tetrahedra": [[a, b, c, d], ...],
//     "material": { "model": "linear" | "corotational" | "stvk" | "mooney-rivlin",
//                   "young_modulus", "poisson_ratio" | "c1", "c2", "bulk_modulus",
//                   "stabilization" },
//     "density", "gravity", "fixed", "prescribed": [[node, component, m], ...],
//     "loads": [[node, component, N], ...], "load_steps", "tolerance" }
// (JavaScript comments allowed).
#pragma once

#include <string>

#include "organsim/fem/static_solver.h"

namespace organsim::cli {

/// Parses a problem from JSON text and validates it (fem::validate). Throws
/// std::runtime_error with one line naming the field or element at fault.
fem::StaticProblem parse_fem_problem(const std::string& text);
/// Reads and parses the problem file at `path`.
fem::StaticProblem read_fem_problem(const std::string& path);

}  // namespace organsim::cli

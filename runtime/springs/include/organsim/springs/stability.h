// The integrators of the mass-spring model and their stability limits: which
// time step keeps an explicit scheme stable on a given network (docs/springs.md).
#pragma once

#include <cstdint>

#include "organsim/springs/network.h"

namespace organsim::springs {

/// The time integrators MassSpring offers (SimulationOptions::integrator says
/// what each does).
enum class Integrator : std::uint8_t { explicit_euler, midpoint, rk4, symplectic_euler, implicit_euler };

/// The stiffest motion of a network linearized at rest, over its free nodes:
/// ω² the largest eigenvalue of M⁻¹K (K the springs' axial stiffness) and γ
/// that of M⁻¹D (their damping) plus the point damping over the lightest free
/// mass. Power iterations: ω and γ are approached from below (within about
/// 10⁻⁴ relative; take a margin).
struct StiffestMode {
  double omega = 0.0;         ///< rad/s
  double damping_rate = 0.0;  ///< 1/s
};
StiffestMode stiffest_mode(const SpringNetwork& network, double point_damping);

/// The largest dt (s) at which `integrator` is stable on the mode
/// ẍ = −ω²x − γẋ: |R(dt·μ)| ≤ 1 at its eigenvalues μ for the explicit ones,
/// dt²ω² + 2·dt·γ < 4 and dt·γ < 2 for symplectic Euler; infinite for implicit
/// Euler, 0 when no step is stable (explicit Euler without damping). Taking ω
/// and γ of different modes together (stiffest_mode) errs on the safe side.
double largest_stable_step(Integrator integrator, const StiffestMode& mode);

}  // namespace organsim::springs

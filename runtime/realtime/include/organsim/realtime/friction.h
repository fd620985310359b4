// Coulomb friction between a tool and the organ, on a contact the force loop
// renders as F(d) = F₀ − K (d − d₀) (docs/realtime.md#contact-rule): where
// F's tangential part exceeds μ times its normal part, the organ slips under
// the tool. Used at 1 kHz by the engine and, to convergence, by the static
// presses of `poke`/`compare`, so that both give the same force. Allocation-
// and exception-free.
#pragma once

#include <Eigen/Core>

namespace organsim::realtime {

/// One slip step: the shift δ of the displacement d within the tangent
/// plane of the unit outward `normal` that takes the tangential force's
/// excess over μ times the normal force off through K's tangential block
/// (a 2 × 2 solve; along the excess alone where that block is not
/// definite). Updates `force` by −K δ and returns δ (zero inside the cone,
/// or where K has no tangential stiffness). K's coupling of the tangential
/// shift to the normal force leaves a remainder that the next step takes.
Eigen::Vector3d slip_step(const Eigen::Matrix3d& stiffness, const Eigen::Vector3d& normal, double friction,
                          Eigen::Vector3d& force) noexcept;

/// Cuts `force` into the cone: a normal part that would pull to zero (the
/// organ pushes the tool, never pulls it), the tangential part to μ times
/// the normal part.
void clip_to_cone(const Eigen::Vector3d& normal, double friction, Eigen::Vector3d& force) noexcept;

}  // namespace organsim::realtime

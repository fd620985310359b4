// The stiffest mode of a network and the largest stable step of each
// integrator on it (mass_spring.h).
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <vector>

#include "organsim/springs/stability.h"

namespace organsim::springs {
namespace {

using Vectors = std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>>;

/// The largest eigenvalue of M^{-1/2} A M^{-1/2} over the free nodes, A the
/// rest-state axial operator Σ c_s (û·(u_a − u_b)) û with c_s from `coefficient`
/// (stiffness or damping), plus with `supports` the node supports' K taken as
/// bilateral (a pressed contact is as stiff along its normal): power iteration
/// from a deterministic start.
template <class Coefficient>
double largest_mass_normalized_eigenvalue(const SpringNetwork& net, Coefficient coefficient, bool supports) {
  const std::size_t n = net.rest.size();
  std::vector<double> scale(n);  // m^{-1/2} on free nodes, 0 on fixed ones
  for (std::size_t i = 0; i < n; ++i) scale[i] = net.fixed[i] ? 0.0 : 1.0 / std::sqrt(net.mass[i]);
  Vectors u(n), w(n);
  for (std::size_t i = 0; i < n; ++i)  // a rough start excites every mode
    u[i] = scale[i] > 0.0 ? Eigen::Vector3d(std::sin(1.0 + 3.1 * i), std::cos(2.0 + 1.7 * i), std::sin(0.5 + 2.3 * i))
                          : Eigen::Vector3d::Zero();
  const Springs& s = net.springs;
  double estimate = 0.0;
  for (int iteration = 0; iteration < 200; ++iteration) {
    double squared = 0.0;
    for (const auto& x : u) squared += x.squaredNorm();
    const double norm = std::sqrt(squared);
    if (!(norm > 0.0)) return 0.0;
    for (auto& x : u) x /= norm;
    std::fill(w.begin(), w.end(), Eigen::Vector3d::Zero());
    for (std::size_t k = 0; k < s.size(); ++k) {
      const Eigen::Vector3d d = net.rest[s.a[k]] - net.rest[s.b[k]];
      const double l = d.norm();
      if (!(l > 0.0)) continue;
      const Eigen::Vector3d axis = d / l;
      const double stretch = axis.dot(scale[s.a[k]] * u[s.a[k]] - scale[s.b[k]] * u[s.b[k]]);
      const Eigen::Vector3d f = coefficient(k) * stretch * axis;
      w[s.a[k]] += scale[s.a[k]] * f;
      w[s.b[k]] -= scale[s.b[k]] * f;
    }
    if (supports)
      for (const NodeSupport& support : net.supports)
        w[support.node] += support.stiffness * scale[support.node] * scale[support.node] * u[support.node];
    double rayleigh = 0.0;
    for (std::size_t i = 0; i < n; ++i) rayleigh += u[i].dot(w[i]);
    if (iteration > 20 && std::abs(rayleigh - estimate) <= 1e-4 * rayleigh) return rayleigh;
    estimate = rayleigh;
    u.swap(w);
  }
  return estimate;
}

}  // namespace

StiffestMode stiffest_mode(const SpringNetwork& network, double point_damping) {
  StiffestMode mode;
  mode.omega =
      std::sqrt(std::max(0.0, largest_mass_normalized_eigenvalue(
                                  network, [&](std::size_t k) { return network.springs.stiffness[k]; }, true)));
  double lightest = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < network.rest.size(); ++i)
    if (!network.fixed[i]) lightest = std::min(lightest, network.mass[i]);
  mode.damping_rate = std::max(0.0, largest_mass_normalized_eigenvalue(
                                        network, [&](std::size_t k) { return network.springs.damping[k]; }, false)) +
                      (std::isfinite(lightest) ? point_damping / lightest : 0.0);
  return mode;
}

double largest_stable_step(Integrator integrator, const StiffestMode& mode) {
  const double w2 = mode.omega * mode.omega, g = mode.damping_rate;
  if (integrator == Integrator::implicit_euler || !(w2 > 0.0 || g > 0.0))
    return std::numeric_limits<double>::infinity();
  // The mode's eigenvalues μ = (−γ ± √(γ² − 4ω²)) / 2.
  const std::complex<double> root = std::sqrt(std::complex<double>(g * g - 4.0 * w2, 0.0));
  const std::complex<double> mu[2] = {0.5 * (-g + root), 0.5 * (-g - root)};
  auto stable = [&](double h) {
    if (integrator == Integrator::symplectic_euler)  // v += h a, x += h v: trace and determinant conditions
      return h * g < 2.0 && h * h * w2 + 2.0 * h * g < 4.0;
    for (const std::complex<double>& m : mu) {
      const std::complex<double> z = h * m;
      std::complex<double> r = 1.0 + z;
      if (integrator == Integrator::midpoint) r += 0.5 * z * z;
      if (integrator == Integrator::rk4) r += 0.5 * z * z + z * z * z / 6.0 + z * z * z * z / 24.0;
      if (std::abs(r) > 1.0) return false;
    }
    return true;
  };
  // Grow the step by 1 % until the mode turns unstable (the regions are
  // intervals along each ray from the origin).
  const double scale = 1.0 / std::max(mode.omega, g);
  double h = 1e-3 * scale;
  if (!stable(h)) return 0.0;  // e.g. explicit Euler on an undamped oscillation
  while (h < 10.0 * scale && stable(1.01 * h)) h *= 1.01;
  return h;
}

}  // namespace organsim::springs

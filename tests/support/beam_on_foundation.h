// Hetényi's beam on an elastic foundation (Beams on Elastic Foundation, 1946,
// ch. II), the closed form the supported beams are checked against.
#pragma once

#include <cmath>
#include <complex>

#include <Eigen/Core>
#include <Eigen/LU>

namespace organsim::testing {

/// A beam of bending stiffness `ei` (N m²) built in at x = 0 (w = w' = 0),
/// resting on a foundation of `k` (N/m per metre of beam, N/m²) and loaded by
/// P at its free end x = L (EI w'' = 0, EI w''' = −P): its deflection at `x`
/// per newton of P (m/N). EI d⁴w/dx⁴ + k w = 0 has the solutions e^{±λx}
/// cos λx and e^{±λx} sin λx, λ = (k / 4EI)^{1/4}; the four end conditions fix
/// their weights. As k → 0, the cantilever's x²(3L − x) / 6EI.
inline double hetenyi_deflection(double x, double length, double ei, double k) {
  const double lambda = std::pow(k / (4 * ei), 0.25);
  const std::complex<double> roots[2] = {{lambda, lambda}, {-lambda, lambda}};
  auto derivative = [&](int root, int part, int order, double at) {
    const std::complex<double> z = std::pow(roots[root], order) * std::exp(roots[root] * at);
    return part == 0 ? z.real() : z.imag();
  };
  Eigen::Matrix4d conditions;
  for (int root = 0; root < 2; ++root)
    for (int part = 0; part < 2; ++part)
      conditions.col(2 * root + part) << derivative(root, part, 0, 0.0), derivative(root, part, 1, 0.0),
          derivative(root, part, 2, length), ei * derivative(root, part, 3, length);
  const Eigen::Vector4d weights = conditions.fullPivLu().solve(Eigen::Vector4d(0, 0, 0, -1));
  double deflection = 0.0;
  for (int root = 0; root < 2; ++root)
    for (int part = 0; part < 2; ++part) deflection += weights[2 * root + part] * derivative(root, part, 0, x);
  return deflection;
}

}  // namespace organsim::testing

// Linear stability of the mass-spring integrators on the paper's grid
// (docs/springs.md): settles the grid under its load (implicit Euler), takes
// the linearization ẍ = K δx + D δẋ about that equilibrium (central
// differences of the model's forces), and reports
//   - the damping rates (eigenvalues of −D, i.e. of M⁻¹ times the damping
//     matrix) and the stiffness rates (eigenvalues of −K, ω²);
//   - the eigenvalues μ of the first-order system [0 I; K D]: the fastest
//     (largest |μ|) and the least damped (largest Re μ);
//   - per explicit integrator, the largest dt at which every mode stays
//     bounded (spectral radius of one step ≤ 1): explicit Euler, midpoint and
//     RK4 through their stability polynomials R(dt·μ), symplectic Euler through
//     the eigenvalues of its step matrix [I + dt²K, dt(I + dt D); dt K, I + dt D];
//     and each one's spectral radius at --at-dt.
// Not a benchmark: a measurement program, like realtime_period. Takes a few
// seconds (15×15) to a few minutes (25×25: dense eigenvalue problems of
// 3,174 unknowns, 22 of them for the symplectic bisection).
//
//   springs_stability [--grid N] [--force FZ] [--damping CS,CSH,CB]
//                     [--point-damping C] [--gravity G] [--at-dt S]
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>

#include "organsim/springs/mass_spring.h"

namespace {

using namespace organsim::springs;
using Matrix = Eigen::MatrixXd;
using Complex = std::complex<double>;
using Points = std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>>;

struct Setup {
  std::uint32_t side = 15;
  double force_z = -5.0;
  double damping[3] = {0.4, 0.4, 0.24};
  double point_damping = 0.0;
  double gravity = 9.8;
  double at_dt = 0.01;
};

/// The accelerations of the free nodes (3 per node, in node order), as MassSpring computes them.
Eigen::VectorXd accelerations(const SpringNetwork& net, const std::vector<int>& free_index, int free_count,
                              const Points& x, const Points& v, const Setup& setup, std::uint32_t loaded) {
  Points f(x.size(), Eigen::Vector3d::Zero());
  const Springs& s = net.springs;
  for (std::size_t k = 0; k < s.size(); ++k) {
    const Eigen::Vector3d d = x[s.a[k]] - x[s.b[k]];
    const double l = d.norm();
    const Eigen::Vector3d u = d / l;
    const Eigen::Vector3d fk =
        (s.stiffness[k] * (l - s.rest_length[k]) + s.damping[k] * u.dot(v[s.a[k]] - v[s.b[k]])) * u;
    f[s.a[k]] -= fk;
    f[s.b[k]] += fk;
  }
  Eigen::VectorXd a(3 * free_count);
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (free_index[i] < 0) continue;
    Eigen::Vector3d total = f[i] - setup.point_damping * v[i];
    if (i == loaded) total.z() += setup.force_z;
    a.segment<3>(3 * free_index[i]) = total / net.mass[i] + Eigen::Vector3d(0.0, 0.0, -setup.gravity);
  }
  return a;
}

Complex stability_polynomial(int method, Complex z) {
  switch (method) {
    case 0: return 1.0 + z;                                                          // explicit Euler
    case 1: return 1.0 + z + z * z / 2.0;                                            // midpoint (any 2-stage RK2)
    default: return 1.0 + z + z * z / 2.0 + z * z * z / 6.0 + z * z * z * z / 24.0;  // RK4
  }
}

bool parse(int argc, char** argv, Setup& s) {
  for (int i = 1; i < argc; ++i) {
    const std::string option = argv[i];
    if (i + 1 >= argc) return false;
    const char* value = argv[++i];
    if (option == "--grid")
      s.side = static_cast<std::uint32_t>(std::atoi(value));
    else if (option == "--force")
      s.force_z = std::atof(value);
    else if (option == "--damping") {
      if (std::sscanf(value, "%lf,%lf,%lf", &s.damping[0], &s.damping[1], &s.damping[2]) != 3) return false;
    } else if (option == "--point-damping")
      s.point_damping = std::atof(value);
    else if (option == "--gravity")
      s.gravity = std::atof(value);
    else if (option == "--at-dt")
      s.at_dt = std::atof(value);
    else
      return false;
  }
  return s.side >= 3 && s.at_dt > 0.0;
}

}  // namespace

int main(int argc, char** argv) {
  Setup setup;
  if (!parse(argc, argv, setup)) {
    std::fprintf(stderr,
                 "usage: springs_stability [--grid N] [--force FZ] [--damping CS,CSH,CB] [--point-damping C] "
                 "[--gravity G] [--at-dt S]\n");
    return 2;
  }
  GridOptions grid;
  grid.columns = grid.rows = setup.side;
  grid.structural_damping = setup.damping[0];
  grid.shear_damping = setup.damping[1];
  grid.bending_damping = setup.damping[2];
  const SpringNetwork net = make_grid_network(grid);
  const std::uint32_t loaded = setup.side / 2 + setup.side * (setup.side / 2);

  // The equilibrium under the load: implicit Euler until it no longer moves.
  SimulationOptions options;
  options.integrator = Integrator::implicit_euler;
  options.dt = 0.01;
  options.gravity = Eigen::Vector3d(0.0, 0.0, -setup.gravity);
  options.point_damping = setup.point_damping;
  options.implicit_cg_iterations = 500;
  MassSpring simulation(net, options);
  simulation.set_external_force(loaded, Eigen::Vector3d(0.0, 0.0, setup.force_z));
  for (int n = 0; n < 10000; ++n)
    if (simulation.step() != StepStatus::ok) {
      std::fprintf(stderr, "springs_stability: implicit Euler blew up settling the grid\n");
      return 1;
    }
  std::vector<int> free_index(net.rest.size(), -1);
  int free_count = 0;
  for (std::size_t i = 0; i < net.rest.size(); ++i)
    if (!net.fixed[i]) free_index[i] = free_count++;
  Points x(net.rest.size()), v(net.rest.size(), Eigen::Vector3d::Zero());
  for (std::size_t i = 0; i < x.size(); ++i) x[i] = simulation.position(static_cast<std::uint32_t>(i));
  const Eigen::VectorXd a0 = accelerations(net, free_index, free_count, x, v, setup, loaded);

  // Linearization: K by central differences, D exactly (the forces are linear in v).
  const int n = 3 * free_count;
  Matrix K(n, n), D(n, n);
  const double h = 1e-7;
  for (std::size_t i = 0; i < x.size(); ++i) {
    if (free_index[i] < 0) continue;
    for (int c = 0; c < 3; ++c) {
      const int column = 3 * free_index[i] + c;
      Points plus = x, minus = x, faster = v;
      plus[i][c] += h;
      minus[i][c] -= h;
      faster[i][c] += 1.0;
      K.col(column) = (accelerations(net, free_index, free_count, plus, v, setup, loaded) -
                       accelerations(net, free_index, free_count, minus, v, setup, loaded)) /
                      (2.0 * h);
      D.col(column) = accelerations(net, free_index, free_count, x, faster, setup, loaded) - a0;
    }
  }
  const Eigen::VectorXd damping_rates = Eigen::SelfAdjointEigenSolver<Matrix>(-0.5 * (D + D.transpose())).eigenvalues();
  const Eigen::VectorXd stiffness_rates =
      Eigen::SelfAdjointEigenSolver<Matrix>(-0.5 * (K + K.transpose())).eigenvalues();
  Matrix A = Matrix::Zero(2 * n, 2 * n);
  A.topRightCorner(n, n).setIdentity();
  A.bottomLeftCorner(n, n) = K;
  A.bottomRightCorner(n, n) = D;
  const Eigen::VectorXcd mu = Eigen::EigenSolver<Matrix>(A, false).eigenvalues();
  int fastest = 0, least_damped = 0;
  for (int i = 1; i < mu.size(); ++i) {
    if (std::abs(mu[i]) > std::abs(mu[fastest])) fastest = i;
    if (mu[i].real() > mu[least_damped].real()) least_damped = i;
  }

  std::printf(
      "grid %ux%u, force (0, 0, %g) N at vertex %u, spring damping %g,%g,%g N s/m, point damping %g N s/m, "
      "gravity %g m/s^2\n",
      setup.side, setup.side, setup.force_z, loaded, setup.damping[0], setup.damping[1], setup.damping[2],
      setup.point_damping, setup.gravity);
  std::printf("equilibrium: loaded vertex at dz = %.4f m (largest residual acceleration %.2g m/s^2)\n",
              x[loaded].z() - net.rest[loaded].z(), a0.cwiseAbs().maxCoeff());
  std::printf("damping rates (eigenvalues of M^-1 C): %.2f to %.2f 1/s\n", damping_rates.minCoeff(),
              damping_rates.maxCoeff());
  std::printf("stiffness rates (eigenvalues of M^-1 K): %.2f to %.2f 1/s^2 (omega up to %.2f rad/s)\n",
              stiffness_rates.minCoeff(), stiffness_rates.maxCoeff(), std::sqrt(stiffness_rates.maxCoeff()));
  std::printf("system eigenvalues: fastest %.2f%+.2fi 1/s (|mu| = %.2f), least damped %.4f%+.4fi 1/s\n",
              mu[fastest].real(), std::abs(mu[fastest].imag()), std::abs(mu[fastest]), mu[least_damped].real(),
              std::abs(mu[least_damped].imag()));

  auto radius = [&](int method, double dt) {
    if (method < 3) {
      double r = 0.0;
      for (int i = 0; i < mu.size(); ++i) r = std::max(r, std::abs(stability_polynomial(method, dt * mu[i])));
      return r;
    }
    const Matrix I = Matrix::Identity(n, n);
    Matrix S(2 * n, 2 * n);
    S << I + dt * dt * K, dt * I + dt * dt * D, dt * K, I + dt * D;
    return Eigen::EigenSolver<Matrix>(S, false).eigenvalues().cwiseAbs().maxCoeff();
  };
  const char* names[] = {"euler", "midpoint", "rk4", "symplectic"};
  std::printf("%-11s %-20s %s\n", "integrator", "largest stable dt", "spectral radius of one step");
  for (int method = 0; method < 4; ++method) {
    // Bisection between 10 µs and 50 ms (the stable set is an interval from 0 here).
    double low = 1e-5, high = 0.05;
    if (radius(method, high) <= 1.0 + 1e-10) low = high;
    for (int iteration = 0; iteration < (method == 3 ? 22 : 50) && low < high; ++iteration) {
      const double dt = 0.5 * (low + high);
      (radius(method, dt) <= 1.0 + 1e-10 ? low : high) = dt;
    }
    std::printf("%-11s %2s%8.3f ms          %.4f at dt %g s\n", names[method], low >= 0.05 ? ">=" : "", low * 1e3,
                radius(method, setup.at_dt), setup.at_dt);
  }
  return 0;
}

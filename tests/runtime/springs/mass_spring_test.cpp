// The mass-spring simulation against analytic and measured references: one
// spring's period and amplitude per integrator, convergence orders, energy
// behaviour, static equilibrium, supports, the dynamic region, blow-up
// detection, held nodes and preallocation.
#include <algorithm>
#include <cmath>
#include <ostream>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "organsim/springs/mass_spring.h"

namespace organsim::springs {

// Readable failure messages (found by argument-dependent lookup).
inline void PrintTo(StepStatus status, std::ostream* os) { *os << (status == StepStatus::ok ? "ok" : "blew_up"); }

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr Integrator kAllIntegrators[] = {Integrator::explicit_euler, Integrator::midpoint, Integrator::rk4,
                                          Integrator::symplectic_euler, Integrator::implicit_euler};

// A mass m on a spring (k, rest length L) to a fixed node at the origin,
// starting at rest stretched by A along x: x(t) = L + A cos(ωt), ω = √(k/m).
struct OneSpring {
  double k = 4.0, m = 0.01, length = 0.05, amplitude = 0.01;
  double omega() const { return std::sqrt(k / m); }
  SpringNetwork network() const {
    SpringNetwork net;
    net.rest = {Eigen::Vector3d::Zero(), Eigen::Vector3d(length + amplitude, 0.0, 0.0)};
    net.mass = {m, m};
    net.fixed = {1, 0};
    net.surface_nodes = 2;
    net.springs.a = {0};
    net.springs.b = {1};
    net.springs.rest_length = {length};
    net.springs.stiffness = {k};
    net.springs.damping = {0.0};
    net.springs.kind = {SpringKind::structural};
    return net;
  }
  SimulationOptions options(Integrator integrator, double omega_dt) const {
    SimulationOptions o;
    o.integrator = integrator;
    o.dt = omega_dt / omega();
    o.gravity.setZero();
    o.energy_growth_limit = 1e9;
    return o;
  }
};

struct Oscillation {
  std::vector<double> down_crossings;  // times where x − L changes sign from + to −, interpolated
  double final_invariant = 0.0;        // √((x − L)² + (v/ω)²) at the end
  double min_invariant = 1e300, max_invariant = 0.0;
};

Oscillation oscillate(const OneSpring& spring, Integrator integrator, double omega_dt, double periods) {
  MassSpring sim(spring.network(), spring.options(integrator, omega_dt));
  const double dt = sim.options().dt, omega = spring.omega();
  const auto steps = static_cast<int>(std::ceil(periods * 2.0 * kPi / omega_dt));
  Oscillation o;
  double previous = spring.amplitude;
  for (int n = 1; n <= steps; ++n) {
    EXPECT_EQ(sim.step(), StepStatus::ok);
    const double u = sim.position(1).x() - spring.length;
    if (previous > 0.0 && u <= 0.0) o.down_crossings.push_back(dt * (n - 1 + previous / (previous - u)));
    previous = u;
    const double invariant = std::hypot(u, sim.velocity(1).x() / omega);
    o.min_invariant = std::min(o.min_invariant, invariant);
    o.max_invariant = std::max(o.max_invariant, invariant);
    o.final_invariant = invariant;
    EXPECT_EQ(sim.position(0), Eigen::Vector3d::Zero());
    EXPECT_EQ(sim.position(1).y(), 0.0);
  }
  return o;
}

double measured_period(const Oscillation& o) {
  return (o.down_crossings.back() - o.down_crossings.front()) / static_cast<double>(o.down_crossings.size() - 1);
}

TEST(OneSpring, StiffestModeAndLargestStableStepsAreTheAnalyticOnes) {
  OneSpring spring;
  SpringNetwork net = spring.network();
  net.rest[1].x() = spring.length;  // the linearization at rest
  StiffestMode mode = stiffest_mode(net, 0.0);
  EXPECT_NEAR(mode.omega, spring.omega(), 1e-9 * spring.omega());
  EXPECT_EQ(mode.damping_rate, 0.0);
  const double w = spring.omega();
  // Undamped: symplectic Euler to ω·dt = 2, RK4 to 2√2; explicit Euler and
  // midpoint amplify an undamped oscillation at any step.
  EXPECT_NEAR(largest_stable_step(Integrator::symplectic_euler, mode) * w, 2.0, 0.02);
  EXPECT_NEAR(largest_stable_step(Integrator::rk4, mode) * w, 2.0 * std::sqrt(2.0), 0.03);
  EXPECT_EQ(largest_stable_step(Integrator::explicit_euler, mode), 0.0);
  EXPECT_EQ(largest_stable_step(Integrator::midpoint, mode), 0.0);
  EXPECT_TRUE(std::isinf(largest_stable_step(Integrator::implicit_euler, mode)));
  // Damped (spring damping d along the spring, point damping c): γ = (d + c)/m;
  // explicit Euler on ẍ = −ω²x − γẋ is stable up to dt = γ/ω² (|1 + dt·μ| = 1).
  net.springs.damping = {0.2};
  mode = stiffest_mode(net, 0.1);
  EXPECT_NEAR(mode.damping_rate, 0.3 / spring.m, 1e-9 * 0.3 / spring.m);
  const double g = mode.damping_rate;
  EXPECT_NEAR(largest_stable_step(Integrator::explicit_euler, mode), g / (w * w), 0.011 * g / (w * w));
  // Symplectic Euler: dt²ω² + 2·dt·γ = 4.
  const double symplectic = (-g + std::sqrt(g * g + 4.0 * w * w)) / (w * w);
  EXPECT_NEAR(largest_stable_step(Integrator::symplectic_euler, mode), symplectic, 0.011 * symplectic);
  // And the simulation agrees: 0.95 of the limit decays, 1.05 of it grows.
  for (const double fraction : {0.95, 1.05}) {
    SimulationOptions o = spring.options(Integrator::symplectic_euler, 1.0);
    o.dt = fraction * symplectic;
    o.point_damping = 0.1;
    SpringNetwork damped = spring.network();
    damped.springs.damping = {0.2};
    MassSpring damped_sim(damped, o);
    double amplitude = 0.0;  // the largest excursion over the last 100 steps (several periods)
    for (int n = 0; n < 400; ++n) {
      damped_sim.step();
      if (n >= 300) amplitude = std::max(amplitude, std::abs(damped_sim.position(1).x() - spring.length));
    }
    if (fraction < 1.0) {
      EXPECT_LT(amplitude, 1e-3 * spring.amplitude);
    } else {
      EXPECT_GT(amplitude, spring.amplitude);
    }
  }
}

// A node on one spring (k) resting against a support (K) along +x: pushed
// into it by a force F it settles at F / (k + K), pulled away at F / k (a
// contact lets go, an attachment holds at F / (k + K)); its reaction and
// the stiffness a tool holding it would feel count the support; the stiffest
// mode is √((k + K) / m); the energy is the spring's and the support's.
TEST(NodeSupport, AContactPushesBackOnlyWhenPressedAndAnAttachmentHoldsBothWays) {
  OneSpring spring;
  constexpr double kSupport = 6.0;  // N/m
  constexpr double kForce = 0.02;   // N
  for (const bool unilateral : {true, false}) {
    SpringNetwork net = spring.network();
    net.rest[1].x() = spring.length;
    net.supports.push_back({1, kSupport, Eigen::Vector3d::UnitX(), unilateral});
    EXPECT_NEAR(stiffest_mode(net, 0.0).omega, std::sqrt((spring.k + kSupport) / spring.m), 1e-6);
    for (const double sign : {1.0, -1.0}) {
      SimulationOptions o = spring.options(Integrator::symplectic_euler, 0.1);
      o.point_damping = 0.2;
      MassSpring sim(net, o);
      sim.set_external_force(1, {sign * kForce, 0.0, 0.0});
      for (int n = 0; n < 20000; ++n) ASSERT_EQ(sim.step(), StepStatus::ok);
      const bool pressed = sign > 0.0 || !unilateral;
      const double stiffness = spring.k + (pressed ? kSupport : 0.0);
      const double u = sim.position(1).x() - spring.length;
      EXPECT_NEAR(u, sign * kForce / stiffness, 1e-9) << "unilateral " << unilateral << ", sign " << sign;
      EXPECT_NEAR(sim.reaction_force(1).x(), -sign * kForce, 1e-9);
      EXPECT_NEAR(sim.contact_stiffness(1)(0, 0), stiffness, 1e-9);
      EXPECT_NEAR(sim.energy().spring, 0.5 * stiffness * u * u, 1e-12);
    }
  }
}

TEST(NodeSupport, ANetworkRefusesABadSupport) {
  OneSpring spring;
  SpringNetwork net = spring.network();
  net.supports.push_back({2, 1.0, Eigen::Vector3d::UnitX(), true});
  EXPECT_THROW(MassSpring(net, spring.options(Integrator::symplectic_euler, 0.1)), std::invalid_argument);
  net.supports = {{1, 1.0, Eigen::Vector3d(2.0, 0.0, 0.0), true}};
  EXPECT_THROW(MassSpring(net, spring.options(Integrator::symplectic_euler, 0.1)), std::invalid_argument);
  net.supports = {{1, -1.0, Eigen::Vector3d::UnitX(), false}};
  EXPECT_THROW(MassSpring(net, spring.options(Integrator::symplectic_euler, 0.1)), std::invalid_argument);
}

TEST(OneSpring, RungeKuttaPeriodAndAmplitudeAreExactAtSmallSteps) {
  const OneSpring spring;
  const double period = 2.0 * kPi * std::sqrt(spring.m / spring.k);
  const Oscillation rk4 = oscillate(spring, Integrator::rk4, 0.01, 3.0);
  ASSERT_EQ(rk4.down_crossings.size(), 3u);
  EXPECT_NEAR(measured_period(rk4), period, 1e-7 * period);
  EXPECT_NEAR(rk4.down_crossings.front(), period / 4.0, 1e-7 * period);
  EXPECT_NEAR(rk4.max_invariant, spring.amplitude, 1e-10 * spring.amplitude);
  EXPECT_NEAR(rk4.min_invariant, spring.amplitude, 1e-10 * spring.amplitude);

  // Midpoint: phase error (ωdt)²/6 per radian, amplitude growth (ωdt)⁴/8 per step.
  const Oscillation midpoint = oscillate(spring, Integrator::midpoint, 0.01, 3.0);
  ASSERT_EQ(midpoint.down_crossings.size(), 3u);
  EXPECT_NEAR(measured_period(midpoint), period, 3e-5 * period);
  const double growth = std::pow(1.0 + std::pow(0.01, 4) / 4.0, 0.5 * std::ceil(3.0 * 2.0 * kPi / 0.01));
  EXPECT_NEAR(midpoint.final_invariant, spring.amplitude * growth, 1e-9 * spring.amplitude);
  EXPECT_NEAR(midpoint.final_invariant, spring.amplitude, 1e-5 * spring.amplitude);
}

TEST(OneSpring, EulerVariantsGrowDecayOrStayBoundedAsTheirAmplificationFactors) {
  const OneSpring spring;
  const double z = 0.05;  // ω dt
  const double periods = 5.0;
  const double steps = std::ceil(periods * 2.0 * kPi / z);
  const double period = 2.0 * kPi / spring.omega();

  // Explicit Euler: |R|² = 1 + z² per step; implicit Euler: 1 / (1 + z²).
  const Oscillation explicit_euler = oscillate(spring, Integrator::explicit_euler, z, periods);
  const double grown = spring.amplitude * std::pow(1.0 + z * z, 0.5 * steps);
  EXPECT_NEAR(explicit_euler.final_invariant, grown, 1e-9 * grown);
  EXPECT_GT(explicit_euler.final_invariant, 2.0 * spring.amplitude);
  const Oscillation implicit_euler = oscillate(spring, Integrator::implicit_euler, z, periods);
  const double decayed = spring.amplitude * std::pow(1.0 + z * z, -0.5 * steps);
  EXPECT_NEAR(implicit_euler.final_invariant, decayed, 1e-9 * decayed);
  EXPECT_LT(implicit_euler.final_invariant, 0.5 * spring.amplitude);

  // Symplectic Euler: the amplitude oscillates within O(ωdt) and does not drift.
  const Oscillation symplectic = oscillate(spring, Integrator::symplectic_euler, z, 20.0);
  EXPECT_GT(symplectic.min_invariant, (1.0 - z) * spring.amplitude);
  EXPECT_LT(symplectic.max_invariant, (1.0 + z) * spring.amplitude);
  ASSERT_GE(symplectic.down_crossings.size(), 19u);
  EXPECT_NEAR(measured_period(symplectic), period, 1e-3 * period);  // phase error (ωdt)²/24
}

// The paper's grid with some options changed.
SpringNetwork paper_grid(std::uint32_t size, double damping_scale = 1.0) {
  GridOptions g;
  g.columns = g.rows = size;
  g.structural_damping *= damping_scale;
  g.shear_damping *= damping_scale;
  g.bending_damping *= damping_scale;
  return make_grid_network(g);
}

std::uint32_t centre_node(std::uint32_t size) { return size / 2 + size * (size / 2); }

std::vector<Eigen::Vector3d> positions(const MassSpring& sim) {
  std::vector<Eigen::Vector3d> p(sim.node_count());
  for (std::uint32_t i = 0; i < sim.node_count(); ++i) p[i] = sim.position(i);
  return p;
}

double max_difference(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  double d = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) d = std::max(d, (a[i] - b[i]).norm());
  return d;
}

std::vector<Eigen::Vector3d> run_grid(Integrator integrator, double dt, double end_time) {
  SimulationOptions o;
  o.integrator = integrator;
  o.dt = dt;
  MassSpring sim(paper_grid(5), o);
  sim.set_external_force(centre_node(5), {0.02, 0.0, -0.05});
  const auto steps = static_cast<int>(std::lround(end_time / dt));
  for (int n = 0; n < steps; ++n) EXPECT_EQ(sim.step(), StepStatus::ok);
  return positions(sim);
}

TEST(Grid, MeasuredConvergenceOrdersAreOneTwoAndFour) {
  // Measured here: explicit Euler 1.01, symplectic Euler 1.00, implicit Euler 1.00, midpoint 1.97, RK4 4.01.
  // A 5×5 paper grid (damped, gravity, a force at the centre) at t = 0.064 s
  // against RK4 at a 16th of the smallest step.
  const double end_time = 0.064;
  const std::vector<Eigen::Vector3d> reference = run_grid(Integrator::rk4, 0.0005 / 16.0, end_time);
  struct Case {
    Integrator integrator;
    double dt, order;
  };
  for (const Case& c : {Case{Integrator::explicit_euler, 0.0005, 1.0}, Case{Integrator::symplectic_euler, 0.0005, 1.0},
                        Case{Integrator::implicit_euler, 0.0005, 1.0}, Case{Integrator::midpoint, 0.001, 2.0},
                        Case{Integrator::rk4, 0.002, 4.0}}) {
    const double coarse = max_difference(run_grid(c.integrator, c.dt, end_time), reference);
    const double fine = max_difference(run_grid(c.integrator, c.dt / 2.0, end_time), reference);
    const double order = std::log2(coarse / fine);
    EXPECT_NEAR(order, c.order, 0.3) << static_cast<int>(c.integrator) << ": errors " << coarse << ", " << fine;
  }
}

TEST(Grid, SymplecticEulerKeepsTheEnergyOfAnUndampedGridWhileExplicitEulerGainsEnergy) {
  auto run = [](Integrator integrator, int steps, double& lowest, double& highest, double& last) {
    SpringNetwork net = paper_grid(7, 0.0);
    net.rest[centre_node(7)].z() += 0.004;  // starts displaced
    net.rest[centre_node(7) + 1].x() += 0.002;
    SimulationOptions o;
    o.integrator = integrator;
    o.dt = 0.004;
    o.gravity.setZero();
    o.energy_growth_limit = 1e12;
    MassSpring sim(std::move(net), o);
    const double initial = sim.energy().total();
    lowest = highest = 1.0;
    for (int n = 0; n < steps; ++n) {
      EXPECT_EQ(sim.step(), StepStatus::ok);
      last = sim.energy().total() / initial;
      lowest = std::min(lowest, last);
      highest = std::max(highest, last);
    }
  };
  double lowest, highest, last;
  run(Integrator::symplectic_euler, 2500, lowest, highest, last);
  EXPECT_GT(lowest, 0.9);
  EXPECT_LT(highest, 1.1);
  run(Integrator::explicit_euler, 250, lowest, highest, last);
  EXPECT_GT(last, 10.0);
  EXPECT_GE(lowest, 1.0 - 1e-9);  // it only gains energy
}

// Σ of the Hooke forces on every free node plus gravity and the external force.
double largest_residual(const MassSpring& sim, std::uint32_t loaded, const Eigen::Vector3d& load) {
  const SpringNetwork& net = sim.network();
  std::vector<Eigen::Vector3d> force(net.rest.size(), Eigen::Vector3d::Zero());
  for (std::size_t k = 0; k < net.springs.size(); ++k) {
    const std::uint32_t a = net.springs.a[k], b = net.springs.b[k];
    const Eigen::Vector3d d = sim.position(a) - sim.position(b);
    const Eigen::Vector3d f = net.springs.stiffness[k] * (d.norm() - net.springs.rest_length[k]) * d.normalized();
    force[a] -= f;
    force[b] += f;
  }
  double largest = 0.0;
  for (std::uint32_t i = 0; i < net.rest.size(); ++i) {
    if (net.fixed[i]) continue;
    force[i] += net.mass[i] * sim.options().gravity + (i == loaded ? load : Eigen::Vector3d::Zero());
    largest = std::max(largest, force[i].norm());
  }
  return largest;
}

TEST(Grid, DampedGridSettlesWhereTheNetForceOnEveryFreeNodeVanishes) {
  const std::uint32_t size = 9;
  const Eigen::Vector3d load(0.05, 0.0, -0.5);
  for (auto [integrator, dt, steps] :
       {std::tuple{Integrator::implicit_euler, 0.02, 300}, std::tuple{Integrator::rk4, 0.004, 1600}}) {
    SimulationOptions o;
    o.integrator = integrator;
    o.dt = dt;
    MassSpring sim(paper_grid(size), o);
    sim.set_external_force(centre_node(size), load);
    for (int n = 0; n < steps; ++n) ASSERT_EQ(sim.step(), StepStatus::ok);
    const double scale = load.norm();
    EXPECT_LT(largest_residual(sim, centre_node(size), load), 1e-8 * scale) << static_cast<int>(integrator);
    EXPECT_LT(sim.position(centre_node(size)).z(), -0.02);  // it really deflected
    for (std::uint32_t i = 0; i < sim.node_count(); ++i) {
      EXPECT_LT(sim.velocity(i).norm(), 1e-8);
      if (sim.network().fixed[i]) {
        EXPECT_EQ(sim.position(i), sim.network().rest[i]);
      }
    }
  }
}

TEST(DynamicRegion, ApproachesTheFullRegionAsTheThresholdGoesToZero) {
  // 15×15 paper grid, no gravity, 0.5 N into the centre, 100 steps of 4 ms.
  const std::uint32_t size = 15;
  auto run = [&](Integrator integrator, Region region, double threshold, std::size_t* active) {
    SimulationOptions o;
    o.integrator = integrator;
    o.dt = 0.004;
    o.gravity.setZero();
    o.region = region;
    o.threshold = threshold;
    MassSpring sim(paper_grid(size), o);
    sim.set_external_force(centre_node(size), {0.0, 0.0, -0.5});
    for (int n = 0; n < 100; ++n) EXPECT_EQ(sim.step(), StepStatus::ok);
    if (active) *active = sim.active_count();
    return positions(sim);
  };
  // Symplectic Euler moves information one ring of springs per step, as the
  // region grows: the region's result becomes the full one exactly. The
  // multi-stage midpoint reaches two rings per step, so a small difference stays.
  for (auto [integrator, smallest] :
       {std::pair{Integrator::symplectic_euler, 1e-6}, std::pair{Integrator::midpoint, 1e-4}}) {
    const std::vector<Eigen::Vector3d> full = run(integrator, Region::all, 0.0, nullptr);
    const double deflection = std::abs(full[centre_node(size)].z());
    ASSERT_GT(deflection, 0.04);
    std::vector<double> differences;
    std::vector<std::size_t> counts;
    for (double threshold : {1e-3, 1e-5, 1e-7}) {
      std::size_t active = 0;
      differences.push_back(max_difference(run(integrator, Region::dynamic, threshold, &active), full));
      counts.push_back(active);
    }
    const int id = static_cast<int>(integrator);
    EXPECT_GT(differences[0], 1e-2 * deflection) << id;  // the 1 mm region is a coarse approximation
    EXPECT_LT(differences[1], 0.1 * differences[0]) << id;
    EXPECT_LT(differences[2], 0.1 * differences[1]) << id;
    EXPECT_LT(differences[2], smallest * deflection) << id;
    EXPECT_LT(counts[0], 13u * 13u) << id;  // the 1 mm region leaves the outer nodes out
    EXPECT_EQ(counts[2], 13u * 13u) << id;
  }
}

TEST(DynamicRegion, StartsAtTheLoadGrowsAndRetiresWhenReleased) {
  const std::uint32_t size = 15, centre = centre_node(size);
  SimulationOptions o;
  o.dt = 0.004;
  o.gravity.setZero();
  o.region = Region::dynamic;
  o.threshold = 1e-4;  // the body springs keep a point load local: neighbours move ~0.3 mm per 5 mm
  MassSpring sim(paper_grid(size), o);
  EXPECT_EQ(sim.active_count(), 0u);
  ASSERT_EQ(sim.step(), StepStatus::ok);  // nothing to do
  EXPECT_EQ(sim.active_count(), 0u);
  sim.set_external_force(centre, {0.0, 0.0, -0.03});  // 5 mm: less than the anchor depth
  ASSERT_EQ(sim.step(), StepStatus::ok);
  EXPECT_EQ(sim.active_count(), 13u);  // the node and its 12 neighbours (structural, shear, bending)
  std::size_t largest = 0;
  for (int n = 0; n < 100; ++n) {
    ASSERT_EQ(sim.step(), StepStatus::ok);
    largest = std::max(largest, sim.active_count());
  }
  EXPECT_GT(largest, 13u);
  EXPECT_LT(largest, 13u * 13u);
  EXPECT_EQ(sim.position(size + 1), sim.network().rest[size + 1]);  // a node near the corner stays put
  sim.clear_external_forces();
  int steps = 0;
  for (; steps < 2000 && sim.active_count() > 0; ++steps) ASSERT_EQ(sim.step(), StepStatus::ok);
  EXPECT_EQ(sim.active_count(), 0u) << steps;
  for (std::uint32_t i = 0; i < sim.node_count(); ++i) {
    EXPECT_LT((sim.position(i) - sim.network().rest[i]).norm(), o.threshold);
    EXPECT_EQ(sim.velocity(i), Eigen::Vector3d::Zero());
  }
  sim.reset();
  EXPECT_EQ(sim.active_count(), 0u);
  EXPECT_EQ(sim.steps(), 0u);
}

TEST(FixedRegion, NodesOutsideItNeverMoveAndItDoesNotGrow) {
  // He et al.'s fixed deformation region (Fig. 5(a)): the vertices within two
  // springs of the load. On the paper's grid each vertex has springs to its
  // structural, shear and bending neighbours, so two hops reach |di|, |dj| ≤ 4
  // and the diamond of the bending springs' reach.
  const std::uint32_t size = 15, centre = centre_node(size);
  SimulationOptions o;
  o.dt = 0.0005;
  o.region = Region::fixed;
  o.region_rings = 2;
  MassSpring sim(paper_grid(size), o);
  sim.set_external_force(centre, {0.0, 0.0, -5.0});
  std::vector<bool> inside(sim.node_count(), false);
  ASSERT_EQ(sim.step(), StepStatus::ok);
  const std::size_t region = sim.active_count();
  for (std::size_t k = 0; k < region; ++k) inside[sim.integrated_nodes()[k]] = true;
  EXPECT_TRUE(inside[centre]);
  EXPECT_TRUE(inside[centre + 4]);   // two bending springs along x
  EXPECT_FALSE(inside[centre + 5]);  // three hops away
  for (int n = 0; n < 400; ++n) {
    ASSERT_EQ(sim.step(), StepStatus::ok);
    ASSERT_EQ(sim.active_count(), region) << n;  // the region keeps its size however far the load pulls
  }
  EXPECT_LT((sim.position(centre) - sim.network().rest[centre]).z(), -0.05);  // 5 N pulls the centre deep
  for (std::uint32_t i = 0; i < sim.node_count(); ++i)
    if (!inside[i]) {
      EXPECT_EQ(sim.position(i), sim.network().rest[i]) << i;
      EXPECT_EQ(sim.velocity(i), Eigen::Vector3d::Zero()) << i;
    }
  // Over the same steps the whole grid (Region::all) moves a vertex outside the
  // region, and the region's centre less deep than the fixed region's.
  SimulationOptions whole = o;
  whole.region = Region::all;
  MassSpring all(paper_grid(size), whole);
  all.set_external_force(centre, {0.0, 0.0, -5.0});
  for (int n = 0; n < 401; ++n) ASSERT_EQ(all.step(), StepStatus::ok);
  EXPECT_GT((all.position(centre + 5) - all.network().rest[centre + 5]).norm(), 1e-3);
  // A new load elsewhere moves the region with it.
  sim.clear_external_forces();
  sim.set_external_force(size + 1, {0.0, 0.0, -1.0});
  ASSERT_EQ(sim.step(), StepStatus::ok);
  bool has_new = false, has_old = false;
  for (std::size_t k = 0; k < sim.active_count(); ++k) {
    has_new |= sim.integrated_nodes()[k] == size + 1;
    has_old |= sim.integrated_nodes()[k] == centre;
  }
  EXPECT_TRUE(has_new);
  EXPECT_FALSE(has_old);
  o.region_rings = 0;
  EXPECT_THROW(MassSpring(paper_grid(3), o), std::invalid_argument);
}

TEST(HeldNode, APullFeelsAForceOppositeToAPressOfTheSameDepth) {
  // The centre of He et al.'s grid held 5 mm above and 5 mm below its rest,
  // settled without gravity: a pull must feel the press's force reversed.
  const std::uint32_t size = 15, centre = centre_node(size);
  Eigen::Vector3d reaction[2];
  for (int pull = 0; pull < 2; ++pull) {
    SimulationOptions o;
    o.integrator = Integrator::implicit_euler;
    o.dt = 0.002;
    o.gravity.setZero();
    MassSpring sim(paper_grid(size), o);
    const double depth = pull ? 0.005 : -0.005;
    sim.hold(centre, sim.network().rest[centre] + Eigen::Vector3d(0, 0, depth));
    for (int n = 0; n < 1000; ++n) ASSERT_EQ(sim.step(), StepStatus::ok);
    reaction[pull] = sim.reaction_force(centre);
  }
  EXPECT_GT(reaction[0].z(), 0.0);  // pressed down, the grid pushes the tool up
  EXPECT_LT(reaction[1].z(), 0.0);  // pulled up, it pulls the tool down
  // Nearly antisymmetric at 5 mm: the springs' geometric nonlinearity is small.
  EXPECT_NEAR(reaction[1].z(), -reaction[0].z(), 0.1 * reaction[0].z());
  EXPECT_LT(std::abs(reaction[0].x()) + std::abs(reaction[0].y()), 1e-9);
}

TEST(BlowUp, ThePapersSettingsDivergeWithExplicitEulerAndTheLastGoodStateIsKept) {
  // dt 0.01, mass 0.01, k 2/2/1.2, c 0.4/0.4/0.24, body ×2, 5 N at the centre of 15×15.
  const std::uint32_t size = 15, centre = centre_node(size);
  SimulationOptions o;
  o.integrator = Integrator::explicit_euler;
  o.dt = 0.01;
  MassSpring sim(paper_grid(size), o);
  sim.set_external_force(centre, {0.0, 0.0, -5.0});
  StepStatus status = StepStatus::ok;
  int taken = 0;
  for (; taken < 100 && status == StepStatus::ok; ++taken) status = sim.step();
  ASSERT_EQ(status, StepStatus::blew_up);
  EXPECT_FALSE(sim.stable());
  EXPECT_EQ(sim.steps(), static_cast<std::uint64_t>(taken - 1));
  EXPECT_LE(sim.steps(), 5u);                 // λ·dt ≈ 3.3 > 2: the fastest mode grows ×2.3 per step
  EXPECT_GT(sim.position(centre).z(), -0.2);  // caught while the centre is still within its equilibrium depth (0.3 m)
  const std::vector<Eigen::Vector3d> kept = positions(sim);
  for (std::uint32_t i = 0; i < sim.node_count(); ++i) {
    EXPECT_TRUE(sim.position(i).allFinite());
    EXPECT_TRUE(sim.velocity(i).allFinite());
  }
  // The kept state is the one after the last good step, bit for bit.
  MassSpring replay(paper_grid(size), o);
  replay.set_external_force(centre, {0.0, 0.0, -5.0});
  for (std::uint64_t n = 0; n < sim.steps(); ++n) ASSERT_EQ(replay.step(), StepStatus::ok);
  EXPECT_EQ(positions(replay), kept);
  // Once unstable: nothing changes until reset().
  EXPECT_EQ(sim.step(), StepStatus::blew_up);
  EXPECT_EQ(positions(sim), kept);
  sim.reset();
  EXPECT_TRUE(sim.stable());
  EXPECT_EQ(sim.position(centre), sim.network().rest[centre]);
  EXPECT_EQ(sim.step(), StepStatus::ok);

  // The same load is integrated without a false alarm by RK4 at 4 ms, implicit
  // Euler at 10 ms and explicit Euler at 3 ms (stable: measured limits 3.6 and 5.0 ms).
  for (auto [integrator, dt] : {std::pair{Integrator::rk4, 0.004}, std::pair{Integrator::implicit_euler, 0.01},
                                std::pair{Integrator::explicit_euler, 0.003}}) {
    o.integrator = integrator;
    o.dt = dt;
    MassSpring stable(paper_grid(size), o);
    stable.set_external_force(centre, {0.0, 0.0, -5.0});
    for (int n = 0; n < 300; ++n) ASSERT_EQ(stable.step(), StepStatus::ok) << static_cast<int>(integrator) << " " << n;
  }
}

TEST(BlowUp, NonFiniteStatesAreCaught) {
  SimulationOptions o;
  o.integrator = Integrator::explicit_euler;
  o.dt = 1.0;  // absurd: λ·dt ≈ 300
  o.energy_growth_limit = 1e300;
  MassSpring sim(paper_grid(5), o);
  sim.set_external_force(centre_node(5), {0.0, 0.0, -5.0});
  StepStatus status = StepStatus::ok;
  for (int n = 0; n < 1000 && status == StepStatus::ok; ++n) status = sim.step();
  EXPECT_EQ(status, StepStatus::blew_up);
  for (std::uint32_t i = 0; i < sim.node_count(); ++i) EXPECT_TRUE(sim.position(i).allFinite());
}

TEST(HeldNode, FollowsItsTargetAndReportsTheSpringForces) {
  // A free node between four fixed ones (springs along ±x, ±y), held off-centre.
  SpringNetwork net;
  net.rest = {{0, 0, 0}, {-0.01, 0, 0}, {0.01, 0, 0}, {0, -0.01, 0}, {0, 0.01, 0}};
  net.mass.assign(5, 0.01);
  net.fixed = {0, 1, 1, 1, 1};
  net.surface_nodes = 5;
  for (std::uint32_t j = 1; j <= 4; ++j) {
    net.springs.a.push_back(0);
    net.springs.b.push_back(j);
    net.springs.rest_length.push_back(0.008);  // pre-stretched
    net.springs.stiffness.push_back(3.0);
    net.springs.damping.push_back(0.1);
    net.springs.kind.push_back(SpringKind::structural);
  }
  for (Integrator integrator : kAllIntegrators) {
    SimulationOptions o;
    o.integrator = integrator;
    o.dt = 0.001;
    MassSpring sim(net, o);
    const Eigen::Vector3d target(0.002, -0.001, 0.003);
    sim.hold(0, target);
    ASSERT_EQ(sim.step(), StepStatus::ok);
    EXPECT_EQ(sim.position(0), target);
    EXPECT_EQ(sim.velocity(0), Eigen::Vector3d::Zero());
    EXPECT_EQ(sim.active_count(), 0u);  // nothing is integrated
    auto hooke = [&](const Eigen::Vector3d& p) {
      Eigen::Vector3d f = Eigen::Vector3d::Zero();
      for (std::uint32_t j = 1; j <= 4; ++j) {
        const Eigen::Vector3d d = p - net.rest[j];
        f -= 3.0 * (d.norm() - 0.008) * d.normalized();
      }
      return f;
    };
    EXPECT_LT((sim.reaction_force(0) - hooke(target)).norm(), 1e-15);
    // contact_stiffness is −∂reaction/∂x (central differences).
    const Eigen::Matrix3d k = sim.contact_stiffness(0);
    const double h = 1e-7;
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3d e = h * Eigen::Vector3d::Unit(c);
      const Eigen::Vector3d derivative = (hooke(target + e) - hooke(target - e)) / (2.0 * h);
      EXPECT_LT((-k.col(c) - derivative).norm(), 1e-6 * k.norm()) << c;
    }
    EXPECT_LT((k - k.transpose()).norm(), 1e-12 * k.norm());
    // Released, it springs back towards the centre.
    sim.release(0);
    for (int n = 0; n < 5; ++n) ASSERT_EQ(sim.step(), StepStatus::ok);
    EXPECT_EQ(sim.active_count(), 1u);
    EXPECT_LT(sim.position(0).norm(), target.norm());
  }
}

TEST(HeldNode, DragsItsNeighboursAndTheDynamicRegionFollows) {
  // The centre of a 9×9 paper grid (no gravity) pulled up 1 cm and held.
  const std::uint32_t size = 9, centre = centre_node(size);
  const double lift = 0.01;
  for (Integrator integrator : kAllIntegrators) {
    std::vector<Eigen::Vector3d> result[2];
    Eigen::Vector3d reaction[2];
    for (Region region : {Region::all, Region::dynamic}) {
      SimulationOptions o;
      o.integrator = integrator;
      o.dt = 0.002;
      o.gravity.setZero();
      o.region = region;
      o.threshold = 1e-7;
      MassSpring sim(paper_grid(size), o);
      sim.hold(centre, sim.network().rest[centre] + Eigen::Vector3d(0, 0, lift));
      for (int n = 0; n < 200; ++n) ASSERT_EQ(sim.step(), StepStatus::ok);
      result[static_cast<int>(region)] = positions(sim);
      reaction[static_cast<int>(region)] = sim.reaction_force(centre);
    }
    const int id = static_cast<int>(integrator);
    EXPECT_GT(result[0][centre + 1].z(), 0.05 * lift) << id;  // the neighbours follow
    EXPECT_LT(reaction[0].z(), -0.04) << id;  // the grid pulls the tool down: body spring 4 N/m × 1 cm and more
    EXPECT_LT(max_difference(result[0], result[1]), 1e-4 * lift) << id;
    EXPECT_LT((reaction[0] - reaction[1]).norm(), 1e-4 * reaction[0].norm()) << id;
  }
}

TEST(MassSpring, RefusesUnusableNetworksAndOptions) {
  SimulationOptions o;
  SpringNetwork bad = paper_grid(3);
  bad.springs.b[0] = bad.springs.a[0];
  EXPECT_THROW(MassSpring(bad, o), std::invalid_argument);
  bad = paper_grid(3);
  bad.mass[4] = 0.0;
  EXPECT_THROW(MassSpring(bad, o), std::invalid_argument);
  bad = paper_grid(3);
  bad.springs.stiffness.pop_back();
  EXPECT_THROW(MassSpring(bad, o), std::invalid_argument);
  o.dt = 0.0;
  EXPECT_THROW(MassSpring(paper_grid(3), o), std::invalid_argument);
  o = {};
  o.implicit_cg_iterations = 0;
  EXPECT_THROW(MassSpring(paper_grid(3), o), std::invalid_argument);
}

TEST(MassSpring, StepsKeepTheirBuffersAndFixedNodesNeverMove) {
  // The definitive allocation count is in tests/runtime/realtime/no_allocation_test.cpp.
  for (Region region : {Region::all, Region::dynamic, Region::fixed})
    for (Integrator integrator : kAllIntegrators) {
      SimulationOptions o;
      o.integrator = integrator;
      o.dt = 0.004;
      o.region = region;
      MassSpring sim(paper_grid(7), o);
      const Eigen::Vector3d* first = &sim.position(0);
      const Eigen::Vector3d* velocity = &sim.velocity(0);
      sim.set_external_force(centre_node(7), {0.0, 0.3, -0.5});
      for (int n = 0; n < 50; ++n) {
        ASSERT_EQ(sim.step(), StepStatus::ok);
        if (n == 20) sim.hold(centre_node(7) + 1, sim.position(centre_node(7) + 1));
      }
      EXPECT_EQ(&sim.position(0), first);
      EXPECT_EQ(&sim.velocity(0), velocity);
      for (std::uint32_t i = 0; i < sim.node_count(); ++i)
        if (sim.network().fixed[i]) {
          EXPECT_EQ(sim.position(i), sim.network().rest[i]);
          EXPECT_EQ(sim.velocity(i), Eigen::Vector3d::Zero());
        }
      EXPECT_EQ(sim.steps(), 50u);
    }
}

}  // namespace
}  // namespace organsim::springs
